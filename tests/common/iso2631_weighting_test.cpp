// ISO 2631-1 Wk weighting and the Welch PSD (labels hil, control).
#include "mrd/common/iso2631_weighting.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "mrd/common/welch_psd.hpp"

namespace mrd {
namespace {

constexpr double kPi = 3.14159265358979323846;

// ISO 2631-1:1997 Table 3, Wk weighting factors (x 1000 in the standard), three significant
// digits: the analog formula must agree within 0.5 % (the table's rounding is <= 0.4 % here).
TEST(Iso2631WkTest, AnalogGainMatchesTheStandardsTable) {
  struct Row {
    double f, wk;
  };
  const Row rows[] = {{0.1, 0.0312}, {0.5, 0.418},    {1.0, 0.482},   {2.0, 0.531},  {4.0, 0.967},
                      {5.0, 1.039},  {6.3, 1.054},    {8.0, 1.036},   {10.0, 0.988}, {12.5, 0.902},
                      {16.0, 0.768}, {20.0, 0.636},   {31.5, 0.405},  {50.0, 0.246}, {63.0, 0.186},
                      {80.0, 0.132}, {100.0, 0.0887}, {160.0, 0.0285}};
  for (const Row& r : rows) {
    EXPECT_NEAR(Iso2631WkGain(r.f) / r.wk, 1.0, 0.005) << r.f << " Hz";
  }
  EXPECT_EQ(Iso2631WkGain(0.0), 0.0);
}

// The bilinear cascade at 1 kHz: within 1 % of the analog weighting up to 63 Hz, within 4 %
// at 100 Hz (warping near Nyquist).
TEST(Iso2631WkTest, DigitalFilterFollowsTheAnalogWeighting) {
  const WkFilter wk(1000.0);
  for (const double f : {0.2, 0.5, 1.0, 2.0, 4.0, 8.0, 12.5, 20.0, 31.5, 50.0, 63.0}) {
    EXPECT_NEAR(wk.Gain(f) / Iso2631WkGain(f), 1.0, 0.01) << f << " Hz";
  }
  EXPECT_NEAR(wk.Gain(100.0) / Iso2631WkGain(100.0), 1.0, 0.04);
}

// Step() realises Gain(): a sine's steady-state amplitude through the filter.
TEST(Iso2631WkTest, StepGivesTheGainOnSines) {
  for (const double f : {1.0, 5.0, 20.0}) {
    WkFilter wk(1000.0);
    double peak = 0.0;
    for (int k = 0; k < 60000; ++k) {  // 60 s: the 0.4 Hz high-pass settles
      const double y = wk.Step(std::sin(2 * kPi * f * static_cast<double>(k) / 1000.0));
      if (k > 50000) peak = std::max(peak, std::abs(y));
    }
    EXPECT_NEAR(peak / wk.Gain(f), 1.0, 0.005) << f << " Hz";
  }
  WkFilter wk(1000.0);
  wk.Step(1.0);
  wk.Reset();
  EXPECT_EQ(wk.Step(0.0), 0.0);
}

// Parseval: the PSD integrates to the signal's mean square; a sine's power sits at its bin.
TEST(WelchPsdTest, IntegratesToTheVarianceAndPlacesASine) {
  std::vector<double> x(32768);
  std::uint64_t state = 12345;
  double var = 0.0;
  for (auto& v : x) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    v = static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5;  // uniform, var 1/12
    var += v * v;
  }
  var /= static_cast<double>(x.size());
  Psd p;
  ASSERT_TRUE(WelchPsd(x, 1000.0, 1024, &p));
  double integral = 0.0;
  for (const double d : p.density) integral += d * 1000.0 / 1024.0;
  EXPECT_NEAR(integral / var, 1.0, 0.03);
  EXPECT_EQ(p.segments, 63);
  for (std::size_t n = 0; n < x.size(); ++n)
    x[n] = 2.0 * std::sin(2 * kPi * 125.0 * static_cast<double>(n) / 1000.0);
  ASSERT_TRUE(WelchPsd(x, 1000.0, 1024, &p));
  std::size_t peak = 0;
  integral = 0.0;
  for (std::size_t k = 0; k < p.density.size(); ++k) {
    if (p.density[k] > p.density[peak]) peak = k;
    integral += p.density[k] * 1000.0 / 1024.0;
  }
  EXPECT_DOUBLE_EQ(p.f_hz[peak], 125.0);
  EXPECT_NEAR(integral, 2.0, 0.01);                   // A^2 / 2
  EXPECT_FALSE(WelchPsd(x, 1000.0, 1000, &p));        // not a power of two
  EXPECT_FALSE(WelchPsd({1.0, 2.0}, 1000.0, 8, &p));  // shorter than a segment
  EXPECT_FALSE(WelchPsd(x, 0.0, 1024, &p));
}

}  // namespace
}  // namespace mrd
