// Filters behind `mrd import`: Kaiser low-pass, band-limited resampling, differentiation.
#include "mrd/host/resample.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace mrd::host {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kNees = 3004.8;  // rate of the NEES-2012-1158 runs [Hz]

std::vector<double> Sine(double rate_hz, std::size_t n, double freq_hz, double amp,
                         double phase = 0.3) {
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) {
    x[k] = amp * std::sin(2.0 * kPi * freq_hz * static_cast<double>(k) / rate_hz + phase);
  }
  return x;
}

// Largest |y[i] - f(i / rate)| over i whose instant is at least `margin` seconds from either
// end (the edge extension is tested separately).
template <typename F>
double MaxInteriorError(const std::vector<double>& y, double rate_hz, double margin_s, F f) {
  double worst = 0.0;
  const double duration = static_cast<double>(y.size() - 1) / rate_hz;
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double t = static_cast<double>(i) / rate_hz;
    if (t < margin_s || t > duration - margin_s) continue;
    worst = std::max(worst, std::fabs(y[i] - f(t)));
  }
  return worst;
}

double InteriorRms(const std::vector<double>& y, double rate_hz, double margin_s) {
  double sum = 0.0;
  std::size_t n = 0;
  const double duration = static_cast<double>(y.size() - 1) / rate_hz;
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double t = static_cast<double>(i) / rate_hz;
    if (t < margin_s || t > duration - margin_s) continue;
    sum += y[i] * y[i];
    ++n;
  }
  return std::sqrt(sum / static_cast<double>(n));
}

// |H(f)| of the kernel sampled at rate_hz, by direct DTFT of its taps.
double SampledGain(const KaiserLowPass& lp, double rate_hz, double freq_hz) {
  const auto half = static_cast<int>(std::floor(lp.half_width_s() * rate_hz));
  std::complex<double> h = 0.0;
  for (int k = -half; k <= half; ++k) {
    const double tau = k / rate_hz;
    h += lp.Evaluate(tau) / rate_hz * std::polar(1.0, -2.0 * kPi * freq_hz * tau);
  }
  return std::abs(h);
}

TEST(KaiserLowPassTest, MeetsBandEdgesWhenSampled) {
  const KaiserLowPass lp(400.0, 500.0, 80.0);
  for (double f = 0.0; f <= 400.0; f += 10.0) {
    EXPECT_NEAR(SampledGain(lp, kNees, f), 1.0, 1e-3) << f << " Hz";
  }
  for (double f = 500.0; f <= 0.5 * kNees; f += 7.0) {
    // Kaiser's formulas are approximate: allow 6 dB off the 80 dB design.
    EXPECT_LT(SampledGain(lp, kNees, f), std::pow(10.0, -74.0 / 20.0)) << f << " Hz";
  }
}

TEST(KaiserLowPassTest, RejectsBadBandEdges) {
  EXPECT_THROW(KaiserLowPass(500.0, 400.0, 80.0), std::invalid_argument);
  EXPECT_THROW(KaiserLowPass(0.0, 400.0, 80.0), std::invalid_argument);
  EXPECT_THROW(KaiserLowPass(100.0, 400.0, -1.0), std::invalid_argument);
}

TEST(ResampleTest, RowCountSpansTheInputDuration) {
  EXPECT_EQ(ResampledRows(60096, kNees, 1000.0), 20000u);  // 60095 / 3004.8 = 19.99967 s
  EXPECT_EQ(ResampledRows(3001, 3000.0, 1000.0), 1001u);   // exact multiple keeps the end
  EXPECT_EQ(ResampledRows(1, 3000.0, 1000.0), 1u);
  EXPECT_EQ(Resample(Sine(kNees, 6010, 5.0, 1.0), kNees, 1000.0).size(),
            ResampledRows(6010, kNees, 1000.0));
}

TEST(ResampleTest, SinesBelowCutoffPassWithSmallAmplitudeError) {
  const std::size_t n = 6010;  // 2 s at 3004.8 Hz
  for (const double freq : {5.0, 50.0, 150.0, 390.0}) {
    const auto y = Resample(Sine(kNees, n, freq, 1.0), kNees, 1000.0);
    const double err = MaxInteriorError(
        y, 1000.0, 0.05, [&](double t) { return std::sin(2.0 * kPi * freq * t + 0.3); });
    EXPECT_LT(err, 1e-3) << freq << " Hz";
  }
}

TEST(ResampleTest, TonesAboveNewNyquistAreAttenuatedBy40dB) {
  const std::size_t n = 6010;
  for (const double freq : {510.0, 600.0, 700.0, 1000.0, 1200.0, 1490.0}) {
    const auto y = Resample(Sine(kNees, n, freq, 1.0), kNees, 1000.0);
    const double gain = InteriorRms(y, 1000.0, 0.05) / std::sqrt(0.5);
    EXPECT_LT(20.0 * std::log10(gain), -40.0) << freq << " Hz";
  }
}

TEST(ResampleTest, StraightLineIsExactUpToBothEnds) {
  // Odd reflection continues a straight line and the weights sum to 1, so there is no edge
  // transient; what remains is the kernel's sampled first moment at fractional phases
  // (stop-band leakage, ~1e-8 of the change over one kernel width here).
  std::vector<double> x(3000);
  for (std::size_t k = 0; k < x.size(); ++k) x[k] = 2.0 - 3.0 * static_cast<double>(k) / kNees;
  const auto y = Resample(x, kNees, 1000.0);
  for (std::size_t i = 0; i < y.size(); ++i) {
    EXPECT_NEAR(y[i], 2.0 - 3.0 * static_cast<double>(i) / 1000.0, 1e-6) << i;
  }
}

TEST(ResampleTest, UpsamplingInterpolatesBandLimitedSignal) {
  const auto y = Resample(Sine(1000.0, 2001, 40.0, 1.0), 1000.0, kNees);
  const double err = MaxInteriorError(
      y, kNees, 0.05, [](double t) { return std::sin(2.0 * kPi * 40.0 * t + 0.3); });
  EXPECT_LT(err, 1e-3);
}

TEST(ResampleTest, TooShortInputIsRejected) {
  EXPECT_THROW(Resample(std::vector<double>(20, 1.0), kNees, 1000.0), std::invalid_argument);
}

TEST(CentralDifferenceTest, ExactForQuadraticIncludingEnds) {
  const double rate = 1000.0;
  std::vector<double> x(50);
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double t = static_cast<double>(k) / rate;
    x[k] = 1.0 + 2.0 * t - 40.0 * t * t;
  }
  const auto d = CentralDifference(x, rate);
  for (std::size_t k = 0; k < d.size(); ++k) {
    EXPECT_NEAR(d[k], 2.0 - 80.0 * static_cast<double>(k) / rate, 1e-9) << k;
  }
}

TEST(DeriveVelocityTest, DerivativeOfSineMatchesCosine) {
  const std::size_t n = 3 * 3005;
  for (const double freq : {2.0, 20.0, 60.0}) {
    const double amp = 0.5;  // [cm]
    const auto v = DeriveVelocity(Sine(kNees, n, freq, amp), kNees, 100.0);
    const double peak = 2.0 * kPi * freq * amp;  // [cm/s]
    const double err = MaxInteriorError(
        v, kNees, 0.1, [&](double t) { return peak * std::cos(2.0 * kPi * freq * t + 0.3); });
    // Pass band to 75 Hz: filter ripple 1e-3, central-difference gain >= 0.9931 at 60 Hz.
    EXPECT_LT(err, 0.01 * peak) << freq << " Hz";
  }
}

TEST(DeriveVelocityTest, NoiseAboveCutoffIsRemoved) {
  const std::size_t n = 3 * 3005;
  auto x = Sine(kNees, n, 5.0, 1.0);
  const auto hf = Sine(kNees, n, 400.0, 0.01, 1.1);  // 0.01 cm at 400 Hz: 25 cm/s peak
  for (std::size_t k = 0; k < n; ++k) x[k] += hf[k];
  const auto v = DeriveVelocity(x, kNees, 100.0);
  const double err = MaxInteriorError(v, kNees, 0.1, [](double t) {
    return 2.0 * kPi * 5.0 * std::cos(2.0 * kPi * 5.0 * t + 0.3);
  });
  EXPECT_LT(err, 0.05);  // [cm/s], against 25 cm/s of unfiltered 400 Hz velocity
}

TEST(DeriveVelocityTest, RejectsCutoffAboveNyquist) {
  EXPECT_THROW(DeriveVelocity(Sine(kNees, 6000, 5.0, 1.0), kNees, 1300.0), std::invalid_argument);
  EXPECT_THROW(DeriveVelocity(Sine(kNees, 6000, 5.0, 1.0), kNees, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace mrd::host
