#include "mrd/firmware/model_runtime.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "reference_models.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

// The runtime at T = double (bit-identical to the host's ModelRunner) in every build; the float
// instantiation (MRD_REAL=float) against it: tests/integration/float_accuracy_test.cpp.
using ModelRuntime = BasicModelRuntime<double>;

double Sign(double s) { return s > 0.0 ? 1.0 : (s < 0.0 ? -1.0 : 0.0); }

// The demo model written out term by term, with plain vectors for the history.
class DemoReference {
 public:
  double Step(double v, double E) {
    const double vn = v / 15.0, en = E / 2.25;
    const double f1 = f_.empty() ? 0.0 : f_.back();
    const double vprev = v_.empty() ? 0.0 : v_.back();
    const double y = 0.85 * f1 - 0.02 * f1 * f1 + 0.03 * Sign(vn) + 0.02 * vn +
                     0.08 * en * std::pow(std::fabs(vn), 0.2) * Sign(vn) -
                     0.02 * en * en * Sign(vn) + 0.01 * en * Sign(vprev) + 0.001 * en;
    f_.push_back(y);
    v_.push_back(vn);
    return y * 1500.0;
  }

 private:
  std::vector<double> f_, v_;
};

TEST(ModelRuntimeTest, MatchesStraightforwardReference) {
  ModelRuntime rt;
  ASSERT_EQ(rt.Configure(test::DemoDamperTable()), Error::kOk);
  DemoReference ref;
  double worst = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double v = 12.0 * std::sin(0.01 * k) + 0.5 * std::sin(0.37 * k);
    const double E = 1.125 + 1.1 * std::sin(0.003 * k);
    const double expected = ref.Step(v, E);
    const double got = rt.Step(v, 0.0, E);
    worst = std::max(worst, std::fabs(got - expected) / std::max(1.0, std::fabs(expected)));
  }
  EXPECT_LT(worst, 1e-12);
}

// The lead's host/firmware equivalence rests on this: the runtime's Begin/ForceAt/Finish path
// computes bit-for-bit what ModelRunner::Step (host simulation) computes.
TEST(ModelRuntimeTest, BitIdenticalToModelRunnerStep) {
  const CoefficientTable table = test::DemoDamperTable();
  ModelRuntime rt;
  ASSERT_EQ(rt.Configure(table), Error::kOk);
  ModelRunner runner(table.model);
  for (int k = 0; k < 1000; ++k) {
    const double v = 9.0 * std::sin(0.02 * k);
    const double E = 2.0 * std::fabs(std::sin(0.011 * k));
    rt.Begin(v, 0.0);
    (void)rt.ForceAt(0.3);  // a trial value must not disturb the result
    const double got = rt.Finish(E);
    const double raw[3] = {v, E, 0.0};
    ASSERT_EQ(got, runner.Step(raw)) << "k=" << k;
  }
}

TEST(ModelRuntimeTest, RefusesChannelTheFirmwareDoesNotProvide) {
  CoefficientTable t = test::DemoDamperTable();
  std::strcpy(t.model.channel_names[0].data(), "temperature");
  ModelRuntime rt;
  EXPECT_EQ(rt.Configure(t), Error::kInvalidArgument);
}

TEST(ModelRuntimeTest, RefusesInvalidTable) {
  CoefficientTable t = test::DemoDamperTable();
  t.e_max = -1.0;
  ModelRuntime rt;
  EXPECT_EQ(rt.Configure(t), Error::kOutOfRange);
}

TEST(ModelRuntimeTest, ReadsDisplacementWhenTheModelHasX) {
  CoefficientTable t = test::EmptyTable();
  std::strcpy(t.model.channel_names[0].data(), "x");
  test::AddTerm(t, {{4, 0, 1}}, 1.0);  // f = 1500 * x / 15
  test::AddTerm(t, {{1, 0, 1}}, 0.0);
  ModelRuntime rt;
  ASSERT_EQ(rt.Configure(t), Error::kOk);
  EXPECT_TRUE(rt.reads_displacement());
  EXPECT_FALSE(rt.reads_velocity());
  EXPECT_DOUBLE_EQ(rt.Step(99.0, 1.5, 0.0), 150.0);
}

}  // namespace
}  // namespace mrd::firmware
