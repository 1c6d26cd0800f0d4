// Readable time plots (time_window.hpp): the window flag, the default window, the envelope of
// the overview and the periodicity test that decides whether a force-displacement loop is
// drawn.
#include "mrd/common/time_window.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace mrd {
namespace {

std::vector<double> Times(int n, double dt = 1e-3) {
  std::vector<double> t(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) t[static_cast<std::size_t>(k)] = dt * k;
  return t;
}

TEST(TimeWindowTest, ParsesFromToAndRefusesTheRest) {
  TimeWindow w;
  std::string why;
  ASSERT_TRUE(ParseTimeWindow("2:7.5", &w, &why));
  EXPECT_EQ(w.from_s, 2.0);
  EXPECT_EQ(w.to_s, 7.5);
  ASSERT_TRUE(ParseTimeWindow("-1:1", &w, &why));
  for (const char* bad : {"", "5", "3:2", "2:2", "a:3", "1:b", "1:nan", "1:inf", "1:2:3"}) {
    EXPECT_FALSE(ParseTimeWindow(bad, &w, &why)) << bad;
    EXPECT_NE(why.find(std::string("'") + bad + "'"), std::string::npos) << why;
  }
}

TEST(TimeWindowTest, DefaultIsTheFirstFiveSecondsAndAskedOnesAreClipped) {
  const std::vector<double> t = Times(20001, 1e-3);  // 0 .. 20 s
  std::string note;
  TimeWindow w = PlotWindow(t, nullptr, &note);
  EXPECT_EQ(w.from_s, 0.0);
  EXPECT_EQ(w.to_s, kDefaultWindowS);
  EXPECT_TRUE(note.empty());
  const TimeWindow asked{18.0, 30.0};
  w = PlotWindow(t, &asked, &note);
  EXPECT_EQ(w.from_s, 18.0);
  EXPECT_EQ(w.to_s, 20.0);
  const TimeWindow outside{50.0, 60.0};
  w = PlotWindow(t, &outside, &note);
  EXPECT_EQ(w.to_s, kDefaultWindowS);
  EXPECT_NE(note.find("outside the record"), std::string::npos);
  const SampleRange r = SamplesIn(t, {2.0, 3.0});
  EXPECT_EQ(r.first, 2000U);
  EXPECT_EQ(r.last, 3001U);
  EXPECT_EQ(Slice(t, r).size(), 1001U);
  // A record shorter than the default window is drawn whole.
  w = PlotWindow(Times(1001), nullptr, &note);
  EXPECT_DOUBLE_EQ(w.to_s, 1.0);
}

TEST(TimeWindowTest, EnvelopeKeepsEveryBucketsExtremes) {
  const std::vector<double> t = Times(10000);
  std::vector<double> y(t.size());
  for (std::size_t k = 0; k < y.size(); ++k) y[k] = std::sin(50.0 * t[k]) + (k == 4321 ? 5.0 : 0.0);
  y[7000] = std::nan("");
  std::vector<double> et, ey;
  Envelope(t, y, 100, &et, &ey);
  EXPECT_LE(et.size(), 200U);
  EXPECT_GE(et.size(), 198U);
  double top = -1e9, bottom = 1e9;
  for (const double v : ey) {
    if (std::isfinite(v)) top = std::max(top, v), bottom = std::min(bottom, v);
  }
  EXPECT_NEAR(top, 5.0 + std::sin(50.0 * t[4321]), 1e-12);  // a one-sample spike survives
  EXPECT_LT(bottom, -0.999);
  for (std::size_t i = 1; i < et.size(); ++i) EXPECT_GE(et[i], et[i - 1]);
}

TEST(TimeWindowTest, PeriodicMotionIsToldFromRandomMotion) {
  const std::vector<double> t = Times(20000);
  std::vector<double> sine(t.size()), two_tone(t.size()), noise(t.size()), road(t.size());
  std::mt19937 rng(3);
  std::normal_distribution<double> n01;
  double lp = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    sine[k] = 1.5 * std::sin(2.0 * std::numbers::pi * 2.0 * t[k]);
    two_tone[k] = std::sin(2.0 * std::numbers::pi * 1.0 * t[k]) +
                  0.5 * std::sin(2.0 * std::numbers::pi * 3.0 * t[k]);
    noise[k] = n01(rng);
    lp += 0.01 * (n01(rng) - lp);  // band-limited random motion (~1.6 Hz low-pass)
    road[k] = lp;
  }
  EXPECT_TRUE(LooksPeriodic(sine));
  EXPECT_TRUE(LooksPeriodic(two_tone));
  EXPECT_FALSE(LooksPeriodic(noise));
  EXPECT_FALSE(LooksPeriodic(road));
  EXPECT_FALSE(LooksPeriodic(std::vector<double>(1000, 2.0)));  // at rest
}

}  // namespace
}  // namespace mrd
