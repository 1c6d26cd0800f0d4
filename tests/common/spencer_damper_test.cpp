#include "mrd/sim/spencer_damper.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace mrd {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDt = 1e-3;

// Demanding profile: 4 s of 3 Hz sine at 15 cm/s peak with voltage steps 0 <-> 2.25 V every
// 0.25 s (fast filter transients at high velocity). Returns the force per sample [N].
std::vector<double> RunDemanding(const SpencerParams& p, int substeps) {
  SpencerDamper d(p, substeps);
  const double w = 2 * kPi * 3.0, a = 15.0 / w;
  d.Reset(0.0, 0.0);
  std::vector<double> f;
  double x0 = 0.0, v0 = a * w;
  for (int k = 1; k <= 4000; ++k) {
    const double t = k * kDt;
    const double x1 = a * std::sin(w * t), v1 = a * w * std::cos(w * t);
    const double E = (k / 250) % 2 == 0 ? 0.0 : 2.25;
    f.push_back(d.Step(kDt, x0, v0, x1, v1, E));
    x0 = x1;
    v0 = v1;
  }
  return f;
}

double RelativeChange(const std::vector<double>& a, const std::vector<double>& b) {
  double diff = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    diff = std::max(diff, std::fabs(a[i] - b[i]));
    scale = std::max(scale, std::fabs(b[i]));
  }
  return diff / scale;
}

TEST(SpencerDamperTest, HalvingSubstepChangesForceByLessThan1e6PaperPreset) {
  const auto coarse = RunDemanding(SpencerParams::Paper(), 100);
  const auto fine = RunDemanding(SpencerParams::Paper(), 200);
  EXPECT_LT(RelativeChange(coarse, fine), 1e-6);
}

TEST(SpencerDamperTest, HalvingSubstepChangesForceByLessThan1e6Spencer1997Preset) {
  const auto coarse = RunDemanding(SpencerParams::Spencer1997(), 100);
  const auto fine = RunDemanding(SpencerParams::Spencer1997(), 200);
  EXPECT_LT(RelativeChange(coarse, fine), 1e-6);
}

TEST(SpencerDamperTest, CoarseStepIsNotConvergedSoTheCheckCanFail) {
  // 1 ms RK4 steps on the stiff spencer1997 set are far from the converged answer.
  const auto coarse = RunDemanding(SpencerParams::Spencer1997(), 1);
  const auto fine = RunDemanding(SpencerParams::Spencer1997(), 100);
  EXPECT_GT(RelativeChange(coarse, fine), 1e-3);
}

// Steady sine at constant voltage; returns (x, f) over the last full cycle.
void SteadyLoop(double E, std::vector<double>* xs, std::vector<double>* fs) {
  SpencerDamper d(SpencerParams::Paper(), 20);
  const double w = 2 * kPi * 1.0, a = 15.0 / w;
  d.Reset(0.0, E);
  double x0 = 0.0, v0 = a * w;
  for (int k = 1; k <= 3000; ++k) {
    const double t = k * kDt;
    const double x1 = a * std::sin(w * t), v1 = a * w * std::cos(w * t);
    const double f = d.Step(kDt, x0, v0, x1, v1, E);
    if (k > 2000) {
      xs->push_back(x1);
      fs->push_back(f);
    }
    x0 = x1;
    v0 = v1;
  }
}

TEST(SpencerDamperTest, ForceGrowsWithVoltageAtSameVelocity) {
  std::vector<double> x_lo, f_lo, x_hi, f_hi;
  SteadyLoop(0.0, &x_lo, &f_lo);
  SteadyLoop(2.25, &x_hi, &f_hi);
  const double peak_lo = *std::max_element(f_lo.begin(), f_lo.end());
  const double peak_hi = *std::max_element(f_hi.begin(), f_hi.end());
  EXPECT_GT(peak_hi, 2.0 * peak_lo);
}

TEST(SpencerDamperTest, ForceDisplacementLoopDissipatesEnergy) {
  std::vector<double> xs, fs;
  SteadyLoop(1.0, &xs, &fs);
  // Work done on the damper over one cycle: integral of f dx > 0.
  double work = 0.0;
  for (std::size_t i = 1; i < xs.size(); ++i)
    work += 0.5 * (fs[i] + fs[i - 1]) * (xs[i] - xs[i - 1]);
  EXPECT_GT(work, 0.0);
}

TEST(SpencerDamperTest, PeakForceAtFullVoltageAndFifteenCmPerSecondIsAboutOnePointFiveKn) {
  std::vector<double> xs, fs;
  SteadyLoop(2.25, &xs, &fs);
  const double peak = *std::max_element(fs.begin(), fs.end());
  EXPECT_GT(peak, 1000.0);
  EXPECT_LT(peak, 2200.0);
}

TEST(SpencerDamperTest, VoltageFilterHasTimeConstantOneOverEta) {
  const SpencerParams p = SpencerParams::Paper();
  SpencerDamper d(p, 20);
  d.Reset(0.0, 0.0);
  const auto steps = static_cast<int>(std::lround(10.0 / p.eta / kDt));  // 10 time constants
  // Step E to 2 V at rest; after one time constant u = 2 (1 - 1/e).
  SpencerDamper d2(p, 200);
  d2.Reset(0.0, 0.0);
  const double tau = 1.0 / p.eta;
  d2.Step(tau, 0.0, 0.0, 0.0, 0.0, 2.0);
  EXPECT_NEAR(d2.state().u, 2.0 * (1.0 - std::exp(-1.0)), 1e-9);
  for (int i = 0; i < steps; ++i) d.Step(kDt, 0.0, 0.0, 0.0, 0.0, 2.0);
  EXPECT_NEAR(d.state().u, 2.0, 2.0 * std::exp(-9.0));
}

TEST(SpencerDamperTest, PresetsByName) {
  SpencerParams p;
  ASSERT_TRUE(SpencerParams::FromPreset("spencer1997", &p));
  EXPECT_DOUBLE_EQ(p.gamma, 363.0);
  EXPECT_DOUBLE_EQ(p.x0, 14.3);
  ASSERT_TRUE(SpencerParams::FromPreset("paper", &p));
  EXPECT_DOUBLE_EQ(p.alpha_b, 638.0);
  EXPECT_FALSE(SpencerParams::FromPreset("nope", &p));
}

TEST(SpencerDamperTest, InvalidParametersNameTheField) {
  SpencerParams p;
  p.eta = -1.0;
  const char* reason = nullptr;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "eta");
  p = SpencerParams{};
  p.gamma = std::nan("");
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "gamma");
  EXPECT_TRUE(SpencerParams{}.IsValid(&reason));
}

}  // namespace
}  // namespace mrd
