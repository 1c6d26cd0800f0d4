// ISO 8608 road (common/sim/include/mrd/sim/iso8608_road.hpp): class levels, the realised
// variance against the class's PSD integral, the slope variance (the w = 2 shape), the class
// ratio, determinism from the seed.
#include "mrd/sim/iso8608_road.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace mrd {
namespace {

// Sample variances of height [m^2] and slope [-] over [0, length] every ds [m]. A sampled sum
// of cosines keeps each component's mean square a^2/2 whatever ds is (aliasing moves power,
// it does not remove it), so a coarse ds is fine for the variance.
void SampleVariances(const Iso8608Road& road, double length, double ds, double* var_h,
                     double* var_slope) {
  const auto n = static_cast<long>(length / ds);
  double sh = 0, shh = 0, sd = 0, sdd = 0;
  for (long k = 0; k < n; ++k) {
    double h, d;
    road.Evaluate(static_cast<double>(k) * ds, &h, &d);
    sh += h;
    shh += h * h;
    sd += d;
    sdd += d * d;
  }
  const auto dn = static_cast<double>(n);
  *var_h = shh / dn - (sh / dn) * (sh / dn);
  *var_slope = sdd / dn - (sd / dn) * (sd / dn);
}

TEST(Iso8608RoadTest, ClassLevelsAreSixteenMicroMetreCubedTimesFourPerStep) {
  EXPECT_DOUBLE_EQ(Iso8608Gd0(RoadClass::kA), 16e-6);
  EXPECT_DOUBLE_EQ(Iso8608Gd0(RoadClass::kC), 256e-6);
  EXPECT_DOUBLE_EQ(Iso8608Gd0(RoadClass::kH), 16e-6 * 16384.0);
  EXPECT_DOUBLE_EQ(Iso8608Psd(RoadClass::kC, 0.1), 256e-6);
  EXPECT_DOUBLE_EQ(Iso8608Psd(RoadClass::kC, 0.2), 64e-6);  // w = 2
  RoadClass c = RoadClass::kA;
  EXPECT_TRUE(RoadClassFromChar('c', &c));
  EXPECT_EQ(c, RoadClass::kC);
  EXPECT_TRUE(RoadClassFromChar('H', &c));
  EXPECT_EQ(c, RoadClass::kH);
  EXPECT_FALSE(RoadClassFromChar('I', &c));
  EXPECT_FALSE(RoadClassFromChar('@', &c));
}

TEST(Iso8608RoadTest, ComponentPowerSumsToTheBandIntegral) {
  RoadParams p;
  const Iso8608Road road(p);
  ASSERT_EQ(road.size(), 256);
  const double band = Iso8608BandVariance(RoadClass::kC, p.n_min, p.n_max);
  EXPECT_NEAR(road.variance(), band, 1e-12 * band);
  // Class C over 0.011..2.83 cycles/m: 2.56e-6 (1/0.011 - 1/2.83) = 2.318e-4 m^2, 15.2 mm RMS.
  EXPECT_NEAR(band, 2.318e-4, 0.001e-4);
}

// Height variance is dominated by the longest waves (91 m), so one realisation over a finite
// length scatters around the ensemble value: for a Gaussian road with this PSD the relative
// standard deviation of the sample variance over length L is 1/sqrt(3 n_min L) = 2.5 % at
// L = 50 km (fixed amplitudes scatter less). Per seed within 12 % (~5 sigma); the mean of five
// seeds within 5 % (~4.5 sigma of 1.1 %). A lost factor (e.g. a_i = sqrt(var) instead of
// sqrt(2 var): -50 %) fails both.
TEST(Iso8608RoadTest, SampleVarianceMatchesTheClassIntegral) {
  double mean = 0.0;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    RoadParams p;
    p.seed = seed;
    const Iso8608Road road(p);
    double vh, vs;
    SampleVariances(road, 50e3, 1.37, &vh, &vs);
    const double band = Iso8608BandVariance(p.road_class, p.n_min, p.n_max);
    std::printf("seed %llu: height variance %.4g m^2 (class C band integral %.4g), ratio %.3f\n",
                static_cast<unsigned long long>(seed), vh, band, vh / band);
    EXPECT_NEAR(vh / band, 1.0, 0.12) << "seed " << seed;
    mean += vh / band / 5.0;
  }
  EXPECT_NEAR(mean, 1.0, 0.05);
}

// The slope's PSD is flat for w = 2 ((2 pi n)^2 Gd = const): its variance is set by the short
// waves and converges fast (relative scatter 1/sqrt((n_max - n_min) L) < 1 % at 20 km).
// Together with the height variance (set by the long waves) this checks the PSD at both ends
// of the band. Tolerance 3 %: n_i is drawn inside its bin, so n_i^2 differs from the bin's
// mean of n^2 by up to the bin width (2.2 %), mostly averaging out.
TEST(Iso8608RoadTest, SlopeVarianceMatchesTheFlatSlopeSpectrum) {
  RoadParams p;
  p.road_class = RoadClass::kB;
  const Iso8608Road road(p);
  double vh, vs;
  SampleVariances(road, 20e3, 0.37, &vh, &vs);
  const double band = Iso8608BandSlopeVariance(p.road_class, p.n_min, p.n_max);
  std::printf("slope variance %.4g (band integral %.4g), ratio %.4f\n", vs, band, vs / band);
  EXPECT_NEAR(vs / band, 1.0, 0.03);
  EXPECT_NEAR(road.slope_variance() / band, 1.0, 0.03);
}

TEST(Iso8608RoadTest, ClassCOverClassBIsFourInVariance) {
  RoadParams b;
  b.road_class = RoadClass::kB;
  RoadParams c = b;
  c.road_class = RoadClass::kC;
  const Iso8608Road rb(b), rc(c);
  double vb, vc, sb, sc;
  SampleVariances(rb, 2e3, 0.37, &vb, &sb);
  SampleVariances(rc, 2e3, 0.37, &vc, &sc);
  EXPECT_NEAR(vc / vb, 4.0, 1e-9);
  EXPECT_NEAR(sc / sb, 4.0, 1e-9);
  EXPECT_NEAR(rc.variance() / rb.variance(), 4.0, 1e-12);
}

TEST(Iso8608RoadTest, SeedDeterminesTheRoad) {
  RoadParams p;
  const Iso8608Road a(p), b(p);
  p.seed = 2;
  const Iso8608Road c(p);
  int differ = 0;
  for (int k = 0; k < 100; ++k) {
    const double s = 7.3 * k;
    EXPECT_EQ(a.Height(s), b.Height(s));
    if (a.Height(s) != c.Height(s)) ++differ;
  }
  EXPECT_EQ(differ, 100);
}

TEST(Iso8608RoadTest, SlopeIsTheDerivativeOfHeight) {
  const Iso8608Road road(RoadParams{});
  for (const double s : {0.0, 12.5, 333.3, 1e5}) {
    double h, d;
    road.Evaluate(s, &h, &d);
    const double e = 1e-5;
    EXPECT_NEAR(d, (road.Height(s + e) - road.Height(s - e)) / (2 * e), 1e-6) << s;
    EXPECT_EQ(h, road.Height(s));
  }
}

// The plant's stepping evaluation (rotated phasors, re-anchored every 1024 steps) against the
// direct sum, over 100 000 steps of 2 cm (1 kHz at 20 m/s: 2 km).
TEST(Iso8608RoadTest, RoadTrackFollowsTheDirectEvaluation) {
  const Iso8608Road road(RoadParams{});
  RoadTrack track(road, 0.02);
  track.Reset(5.0);
  double worst_h = 0.0, worst_d = 0.0;
  for (int k = 1; k <= 100000; ++k) {
    track.Advance();
    if (k % 97 != 0 && k % RoadTrack::kReanchor != 1023) continue;  // sample, incl. pre-anchor
    double h, d;
    road.Evaluate(5.0 + 0.02 * k, &h, &d);
    worst_h = std::fmax(worst_h, std::fabs(track.height_m() - h));
    worst_d = std::fmax(worst_d, std::fabs(track.slope() - d));
  }
  EXPECT_NEAR(track.distance_m(), 2005.0, 1e-9);
  EXPECT_LT(worst_h, 1e-11);  // [m], of a 15 mm RMS profile
  EXPECT_LT(worst_d, 1e-10);
}

TEST(Iso8608RoadTest, InvalidParametersGiveAFlatRoadAndAReason) {
  const char* reason = nullptr;
  RoadParams p;
  EXPECT_TRUE(p.IsValid(&reason));
  p.n_min = 0.0;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "n_min");
  p = RoadParams{};
  p.n_max = p.n_min;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "n_max");
  p = RoadParams{};
  p.components = 0;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "components");
  const Iso8608Road flat(p);
  EXPECT_EQ(flat.size(), 0);
  EXPECT_EQ(flat.Height(10.0), 0.0);
  EXPECT_EQ(flat.variance(), 0.0);
}

}  // namespace
}  // namespace mrd
