// Issue 4: the firmware runtime, loaded from an exported and decoded table, gives the same
// force as `mrd simulate` (SimulateModel) over the three validation sets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "mrd/common/table.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem.hpp"
#include "mrd/host/table_export.hpp"
#include "sem_test_util.hpp"

namespace mrd {
namespace {

// A model identified on the reference set (8 iterations of the paper spec).
const host::ModelFile& IdentifiedModel() {
  static const host::ModelFile mf = [] {
    const host::SemSpec spec =
        host::LoadSemSpec(std::string(MRD_SOURCE_DIR) + "/host/specs/paper.toml");
    host::SemOptions o;
    o.max_iterations = 8;
    o.threads = 2;
    const std::vector<host::DataSet> id{test::DamperData("identification")};
    const host::SemResult r = host::Identify(spec, id, {}, o);
    return host::MakeModelFile(spec, r);
  }();
  return mf;
}

// A model whose command enters through a low-pass regressor (test::kLowPassSpec).
const host::ModelFile& LowPassModel() {
  static const host::ModelFile mf = [] {
    const host::SemSpec spec = host::ParseSemSpec(test::kLowPassSpec, "lp.toml");
    host::SemOptions o;
    o.max_iterations = 4;
    o.threads = 2;
    const std::vector<host::DataSet> id{test::DamperData("identification", 10001)};
    return host::MakeModelFile(spec, host::Identify(spec, id, {}, o));
  }();
  return mf;
}

// Firmware runtime vs SimulateModel for iteration k of mf on one data set.
void ExpectEquivalent(const host::ModelFile& mf, int k, const host::DataSet& data);

class HostFirmwareEquivalenceTest : public ::testing::TestWithParam<const char*> {};

TEST_P(HostFirmwareEquivalenceTest, FirmwareRuntimeMatchesSimulateTo1e12) {
  const host::ModelFile& mf = IdentifiedModel();
  ExpectEquivalent(mf, mf.selected, test::DamperData(GetParam()));
}

TEST(HostFirmwareEquivalenceLowPassTest, FirmwareRuntimeMatchesSimulateTo1e12) {
  const host::ModelFile& mf = LowPassModel();
  const int k = mf.iterations.back().iteration;
  bool low_pass = false;
  for (const auto& t : mf.iterations.back().terms) {
    for (const auto& f : t.factors)
      low_pass |= mf.spec.regressors[f.regressor].transform == Transform::kLowPass;
  }
  ASSERT_TRUE(low_pass);
  ExpectEquivalent(mf, k, test::DamperData("v1"));
}

void ExpectEquivalent(const host::ModelFile& mf, int k, const host::DataSet& data) {
  std::vector<double> host_force;
  const host::SimMetrics metrics = host::SimulateModel(mf, k, data, &host_force);
  ASSERT_FALSE(metrics.diverged);

  // Through the binary image, as the firmware loads it.
  const TableBytes image =
      host::TableImage(host::MakeTable(host::ToRuntimeModel(mf, k), 0.0, 2.25));
  const Result<CoefficientTable> table = DecodeTable(image);
  ASSERT_TRUE(table.ok()) << ErrorName(table.error());
  firmware::BasicModelRuntime<double> runtime;  // the double path, in every build
  ASSERT_EQ(runtime.Configure(table.value()), Error::kOk);

  const auto& v = data.Column("v");
  const auto& x = data.Column("x");
  const auto& E = data.Column("E");
  const auto& f = data.Column("f");
  const auto warmup = static_cast<std::size_t>(mf.warmup_samples());
  double worst = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < data.rows(); ++i) {
    if (i < warmup) {
      runtime.Seed(v[i], x[i], E[i], f[i]);
      continue;
    }
    const double fw = runtime.Step(v[i], x[i], E[i]);
    worst = std::max(worst, std::fabs(fw - host_force[i]));
    scale = std::max(scale, std::fabs(host_force[i]));
  }
  EXPECT_GT(scale, 500.0);  // a real force trace, not zeros
  EXPECT_LE(worst, 1e-12 * scale) << data.path;
}

INSTANTIATE_TEST_SUITE_P(ValidationSets, HostFirmwareEquivalenceTest,
                         ::testing::Values("v1", "v2", "v3"));

}  // namespace
}  // namespace mrd
