#include "mrd/host/profiles.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mrd::host {
namespace {

TEST(ProfilesTest, IdentificationIs40SecondsAt1Ms) {
  const Excitation ex = MakeExcitation("identification", 1);
  ASSERT_EQ(ex.t.size(), 40001u);
  EXPECT_DOUBLE_EQ(ex.t.front(), 0.0);
  EXPECT_NEAR(ex.t.back(), 40.0, 1e-9);
}

TEST(ProfilesTest, IdentificationCoversVoltageRangeAndVelocity) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Excitation ex = MakeExcitation("identification", seed);
    EXPECT_EQ(*std::min_element(ex.E.begin(), ex.E.end()), 0.0);
    EXPECT_EQ(*std::max_element(ex.E.begin(), ex.E.end()), 2.25);
    const auto [vmin, vmax] = std::minmax_element(ex.v.begin(), ex.v.end());
    EXPECT_NEAR(*vmax, 15.0, 0.1);
    EXPECT_NEAR(*vmin, -15.0, 0.1);
  }
}

TEST(ProfilesTest, VelocityIsTheDerivativeOfDisplacement) {
  for (const std::string& name : ReferenceProfileNames()) {
    const Excitation ex = MakeExcitation(name, 7);
    // The trapezoidal integral of v reproduces x; ramp corners between samples cost
    // O(dt * jump) each, far below the tolerance, while a wrong derivative would not.
    double integral = ex.x[0], worst = 0.0;
    for (std::size_t k = 1; k < ex.t.size(); ++k) {
      integral += 0.5 * (ex.v[k] + ex.v[k - 1]) * (ex.t[k] - ex.t[k - 1]);
      worst = std::max(worst, std::fabs(integral - ex.x[k]));
    }
    EXPECT_LT(worst, 0.05) << name;
  }
}

TEST(ProfilesTest, SameSeedSameDataOtherSeedOtherData) {
  const Excitation a = MakeExcitation("v1", 5), b = MakeExcitation("v1", 5),
                   c = MakeExcitation("v1", 6);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.E, b.E);
  EXPECT_NE(a.x, c.x);
}

TEST(ProfilesTest, V2IsZeroVoltsThenFullVoltage) {
  const Excitation ex = MakeExcitation("v2", 1);
  for (std::size_t k = 0; k < ex.t.size(); ++k) EXPECT_EQ(ex.E[k], ex.t[k] < 10.0 ? 0.0 : 2.25);
}

TEST(ProfilesTest, V3IsAtConstantFullVoltageWithPeakVelocity15) {
  const Excitation ex = MakeExcitation("v3", 1);
  EXPECT_TRUE(std::all_of(ex.E.begin(), ex.E.end(), [](double e) { return e == 2.25; }));
  double vmax = 0.0;
  for (double v : ex.v) vmax = std::max(vmax, std::fabs(v));
  EXPECT_NEAR(vmax, 15.0, 1e-9);
  EXPECT_NEAR(ex.x.back(), 0.0, 1e-6);
}

TEST(ProfilesTest, IdentificationForceIsOfOrder1500N) {
  const Excitation ex = MakeExcitation("identification", 1);
  const auto f = SimulateReferenceDamper(SpencerParams::Paper(), ex);
  const auto [fmin, fmax] = std::minmax_element(f.begin(), f.end());
  EXPECT_GT(*fmax, 1000.0);
  EXPECT_LT(*fmax, 2200.0);
  EXPECT_LT(*fmin, -1000.0);
  EXPECT_GT(*fmin, -2200.0);
}

TEST(ProfilesTest, UnknownProfileThrows) {
  EXPECT_THROW(MakeExcitation("v9", 1), std::invalid_argument);
}

// The list in the message is built from ReferenceProfileNames(); today's text, word for word.
TEST(ProfilesTest, UnknownProfileNamesTheExpectedOnes) {
  try {
    MakeExcitation("v9", 1);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "unknown profile 'v9' (expected identification, v1, v2, v3 or wide)");
  }
}

}  // namespace
}  // namespace mrd::host
