// Issue 13: host simulation (mrd simulate's SimulateModel) and the firmware runtime, loaded
// from the exported version 2 table, agree to 1e-12 for models with the saturating
// regressors tanh and clip, on inputs and on the fed-back output (labels robust, firmware).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "mrd/common/table.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "mrd/host/model_export.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem.hpp"
#include "mrd/host/table_export.hpp"
#include "sem_test_util.hpp"

namespace mrd {
namespace {

// The given structure with its least-squares coefficients: the tolerance pick of the only
// iteration, no cross-validated term moves, no output-error refinement (those search extras
// cost half a minute per case and change nothing this equivalence is about).
constexpr const char* kSpec = R"(output = "f"
[algorithm]
selection = "tolerance"
refine = false
[[regressor]]
name = "y"
signal = "f"
powers = [1, 2]
delays = [1]
[[regressor]]
name = "t"
signal = "f"
transform = "tanh"
scale = 0.5
powers = [1]
delays = [1]
[[regressor]]
name = "u1"
signal = "E"
powers = [1, 2]
[[regressor]]
name = "w"
signal = "v"
transform = "tanh"
scale = 0.2
powers = [1, 2, 3]
delays = [0, 1]
[[regressor]]
name = "c"
signal = "v"
transform = "clip"
limit = 0.5
powers = [1, 2]
delays = [0, 2]
)";

class SaturatingEquivalenceTest : public ::testing::TestWithParam<const char*> {};

TEST_P(SaturatingEquivalenceTest, FirmwareRuntimeMatchesSimulateTo1e12) {
  const host::SemSpec spec = host::ParseSemSpec(kSpec, "sat.toml");
  host::SemOptions o;
  o.max_iterations = 0;  // the given structure, LS coefficients
  o.initial = std::vector<std::string>{"y(k-1)",       "t(k-1)",     "w(k)",
                                       "w(k-1)*u1(k)", "c(k)*u1(k)", "c(k-2)^2"};
  const std::vector<host::DataSet> id{test::DamperData("identification")};
  const host::ModelFile mf = host::MakeModelFile(spec, host::Identify(spec, id, {}, o));
  const host::DataSet data = test::DamperData(GetParam());

  std::vector<double> host_force;
  const host::SimMetrics metrics = host::SimulateModel(mf, 0, data, &host_force);
  ASSERT_FALSE(metrics.diverged);
  CoefficientTable t = host::MakeTable(host::ToRuntimeModel(mf, 0), 0.0, 2.25);
  ASSERT_TRUE(host::SetTableEnvelope(mf, &t));
  const Result<CoefficientTable> table = DecodeTable(host::TableImage(t));
  ASSERT_TRUE(table.ok()) << ErrorName(table.error());
  int tanh = 0, clip = 0;
  for (std::size_t r = 0; r < table.value().model.num_regressors; ++r) {
    tanh += table.value().model.regressors[r].transform == Transform::kTanh;
    clip += table.value().model.regressors[r].transform == Transform::kClip;
  }
  ASSERT_EQ(tanh, 2);  // on v and on the output
  ASSERT_EQ(clip, 1);
  firmware::BasicModelRuntime<double> runtime;
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
  EXPECT_GT(scale, 500.0);  // a real force trace
  EXPECT_LE(worst, 1e-12 * scale) << data.path;
}

INSTANTIATE_TEST_SUITE_P(ValidationSets, SaturatingEquivalenceTest,
                         ::testing::Values("v1", "v2", "v3", "wide"));

}  // namespace
}  // namespace mrd
