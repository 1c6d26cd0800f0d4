// The fit's exact Jacobian (host/src/spencer_sensitivity.hpp): its residuals are the
// simulator's to the bit, its columns match central differences of the simulator, splitting
// the columns (over threads) changes nothing, and a diverging simulation is reported as the
// simulator reports it.
#include "spencer_sensitivity.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "mrd/params/spencer_params_file.hpp"

namespace mrd::host {
namespace {

constexpr int kP = kSpencerParamCount;
constexpr int kSubsteps = 8;
constexpr double kEMax = 2.25;

// 0.4 s of a two-sine stroke [cm] with a voltage staircase crossing the e_max clamp.
FitRun Stroke() {
  FitRun r;
  r.name = "stroke";
  r.dt = 1e-3;
  for (int k = 0; k <= 400; ++k) {
    const double t = k * r.dt;
    const double w1 = 2 * M_PI * 3.1, w2 = 2 * M_PI * 7.3;
    r.x.push_back(0.8 * std::sin(w1 * t) + 0.2 * std::sin(w2 * t + 0.4));
    r.v.push_back(0.8 * w1 * std::cos(w1 * t) + 0.2 * w2 * std::cos(w2 * t + 0.4));
    r.E.push_back(0.6 * static_cast<double>(k / 50 % 5));  // 0 ... 2.4 V (clamped)
    r.f.push_back(100.0 * std::sin(w1 * t + 0.3));         // any measured force
  }
  return r;
}

std::array<double, kP> ToArray(SpencerParams p) {
  params::SpencerField f[params::kSpencerFieldCount];
  params::SpencerFields(&p, f);
  std::array<double, kP> a{};
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = *f[i].value;
  return a;
}

SpencerParams FromArray(const std::array<double, kP>& a) {
  SpencerParams p;
  params::SpencerField f[params::kSpencerFieldCount];
  params::SpencerFields(&p, f);
  for (std::size_t i = 0; i < a.size(); ++i) *f[i].value = a[i];
  return p;
}

// Spencer 1997 with a non-integer n (the pow() branch) and a non-zero x0.
SpencerParams Fractional() {
  SpencerParams p = SpencerParams::Spencer1997();
  p.n = 1.37;
  p.x0 = 2.1;
  p.beta = 40.0;
  return p;
}

std::vector<double> Residual(const std::array<double, kP>& a, const FitRun& run) {
  std::vector<double> f;
  EXPECT_TRUE(SimulateRunForce(FromArray(a), run, kSubsteps, kEMax, &f));
  for (std::size_t k = 0; k < f.size(); ++k) f[k] -= run.f[k];
  return f;
}

// The parameter sets the cases run on, by index (0 paper, 1 spencer1997, 2 fractional n).
SpencerParams Case(int i) {
  return i == 0 ? SpencerParams::Paper() : i == 1 ? SpencerParams::Spencer1997() : Fractional();
}

class SpencerSensitivityTest : public ::testing::TestWithParam<int> {};

TEST_P(SpencerSensitivityTest, ResidualsAreTheSimulatorsBitForBit) {
  const FitRun run = Stroke();
  const auto a = ToArray(Case(GetParam()));
  std::array<double, kP> scale{};
  scale.fill(1.0);
  std::vector<double> r(run.x.size()), jac(run.x.size() * kP);
  ASSERT_TRUE(SpencerSensitivity(a.data(), run, kSubsteps, kEMax, 0, kP, scale.data(), r.data(),
                                 jac.data(), kP));
  const std::vector<double> want = Residual(a, run);
  for (std::size_t k = 0; k < r.size(); ++k) ASSERT_EQ(r[k], want[k]) << "row " << k;
}

TEST_P(SpencerSensitivityTest, ColumnsMatchCentralDifferencesOfTheSimulator) {
  const FitRun run = Stroke();
  const auto a = ToArray(Case(GetParam()));
  std::array<double, kP> scale{};
  for (std::size_t j = 0; j < scale.size(); ++j) scale[j] = 0.5 + 0.1 * static_cast<double>(j);
  const std::size_t rows = run.x.size();
  std::vector<double> jac(rows * kP);
  ASSERT_TRUE(SpencerSensitivity(a.data(), run, kSubsteps, kEMax, 0, kP, scale.data(), nullptr,
                                 jac.data(), kP));
  for (std::size_t j = 0; j < static_cast<std::size_t>(kP); ++j) {
    const double h = 1e-6 * std::max(1.0, std::fabs(a[j]));
    auto up = a, down = a;
    up[j] += h;
    down[j] -= h;
    const std::vector<double> ru = Residual(up, run), rd = Residual(down, run);
    double diff2 = 0.0, norm2 = 0.0;
    for (std::size_t k = 0; k < rows; ++k) {
      const double fd = (ru[k] - rd[k]) / (2.0 * h) * scale[j];
      diff2 += (jac[k * kP + j] - fd) * (jac[k * kP + j] - fd);
      norm2 += fd * fd;
    }
    ASSERT_GT(norm2, 0.0) << "column " << j << " does not move the force";
    EXPECT_LT(std::sqrt(diff2 / norm2), 1e-5) << "column " << j;
  }
}

TEST_P(SpencerSensitivityTest, SplittingTheColumnsChangesNothing) {
  const FitRun run = Stroke();
  const auto a = ToArray(Case(GetParam()));
  std::array<double, kP> scale{};
  scale.fill(2.0);
  const std::size_t rows = run.x.size();
  std::vector<double> all(rows * kP), split(rows * kP, -1.0);
  ASSERT_TRUE(SpencerSensitivity(a.data(), run, kSubsteps, kEMax, 0, kP, scale.data(), nullptr,
                                 all.data(), kP));
  ASSERT_TRUE(SpencerSensitivity(a.data(), run, kSubsteps, kEMax, 0, 5, scale.data(), nullptr,
                                 split.data(), kP));
  ASSERT_TRUE(SpencerSensitivity(a.data(), run, kSubsteps, kEMax, 5, kP, scale.data(), nullptr,
                                 split.data(), kP));
  EXPECT_EQ(all, split);
}

INSTANTIATE_TEST_SUITE_P(Presets, SpencerSensitivityTest, ::testing::Values(0, 1, 2),
                         [](const ::testing::TestParamInfo<int>& i) {
                           return std::string(i.param == 0   ? "paper"
                                              : i.param == 1 ? "spencer1997"
                                                             : "fractional_n");
                         });

TEST(SpencerSensitivityDivergenceTest, ReportedWhereTheSimulatorReportsIt) {
  const FitRun run = Stroke();
  SpencerParams p = SpencerParams::Spencer1997();
  p.A = 1e12;  // z (and the force) explode within the first samples
  p.gamma = 0.0;
  p.beta = 0.0;
  std::vector<double> f;
  ASSERT_FALSE(SimulateRunForce(p, run, kSubsteps, kEMax, &f));
  const auto a = ToArray(p);
  std::array<double, kP> scale{};
  scale.fill(1.0);
  std::vector<double> r(run.x.size()), jac(run.x.size() * kP);
  EXPECT_FALSE(SpencerSensitivity(a.data(), run, kSubsteps, kEMax, 0, kP, scale.data(), r.data(),
                                  jac.data(), kP));
}

// The polish splits each Jacobian's columns over the threads: the fit is the same on 1 thread.
TEST(SpencerSensitivityThreadsTest, TheFitDoesNotDependOnTheThreadCount) {
  FitRun run = Stroke();
  std::vector<double> f;
  ASSERT_TRUE(SimulateRunForce(Fractional(), run, kSubsteps, kEMax, &f));
  run.f = f;
  SpencerFitOptions o;
  o.substeps = kSubsteps;
  o.scatter_starts = 1;
  o.search_s = 0.2;
  o.search_iterations = 4;
  o.polish_starts = 2;
  o.polish_iterations = 4;
  o.threads = 1;
  const SpencerFitResult one = FitSpencer({run}, o);
  o.threads = 2;
  const SpencerFitResult two = FitSpencer({run}, o);
  EXPECT_EQ(ToArray(one.params), ToArray(two.params));
  EXPECT_EQ(one.cost, two.cost);
}

}  // namespace
}  // namespace mrd::host
