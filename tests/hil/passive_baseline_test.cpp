// The best passive baseline (passive_baseline.hpp), labels hil, control: the grid, the best
// setting per metric on a synthetic case with a known minimum, comfort at equal road holding,
// and the quarter car's grid (deterministic, Wk scored).
#include "mrd/hil/study/passive_baseline.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil {
namespace {

TEST(PassiveGridTest, VoltagesCoverTheRangeWithTheStep) {
  std::vector<double> v;
  std::string error;
  ASSERT_TRUE(GridVoltages(0.0, 2.25, 0.05, &v, &error));
  ASSERT_EQ(v.size(), 46u);
  EXPECT_DOUBLE_EQ(v.front(), 0.0);
  EXPECT_DOUBLE_EQ(v.back(), 2.25);
  EXPECT_NEAR(v[17], 0.85, 1e-12);
  ASSERT_TRUE(GridVoltages(0.0, 2.25, 1.0, &v, &error));  // the end is always in
  EXPECT_EQ(v, (std::vector<double>{0.0, 1.0, 2.0, 2.25}));
  EXPECT_FALSE(GridVoltages(0.0, 2.25, 0.0, &v, &error));
  EXPECT_NE(error.find("step > 0"), std::string::npos);
  EXPECT_FALSE(GridVoltages(0.0, 2.25, -0.1, &v, &error));
  EXPECT_FALSE(GridVoltages(0.0, 2.25, NAN, &v, &error));
  EXPECT_FALSE(GridVoltages(3.0, 2.25, 0.1, &v, &error));
  EXPECT_FALSE(GridVoltages(0.0, 2.25, 1e-9, &v, &error));
}

// Synthetic metrics with known minima: body acc (V - 0.85)^2 + 1, Wk (V - 0.4)^2 + 0.5,
// tyre load (V - 1.6)^2 * 100 + 700, travel 2 - V / 2 (best at E_max).
RidePoint Synthetic(double v) {
  RidePoint p;
  p.volts = v;
  p.body_accel_rms = (v - 0.85) * (v - 0.85) + 1.0;
  p.body_accel_wk_rms = (v - 0.4) * (v - 0.4) + 0.5;
  p.tyre_load_rms_n = (v - 1.6) * (v - 1.6) * 100.0 + 700.0;
  p.travel_rms_cm = 2.0 - v / 2.0;
  return p;
}

TEST(PassiveGridTest, FindsTheKnownMinimumOfASyntheticCase) {
  std::vector<double> volts;
  std::string error;
  ASSERT_TRUE(GridVoltages(0.0, 2.25, 0.05, &volts, &error));
  std::vector<RidePoint> grid;
  for (const double v : volts) grid.push_back(Synthetic(v));
  EXPECT_NEAR(BestOf(grid, RideMetric::kBodyAccel).volts, 0.85, 1e-9);
  EXPECT_NEAR(BestOf(grid, RideMetric::kBodyAccel).value, 1.0, 1e-12);
  EXPECT_NEAR(BestOf(grid, RideMetric::kBodyAccelWk).volts, 0.40, 1e-9);
  EXPECT_NEAR(BestOf(grid, RideMetric::kTyreLoad).volts, 1.60, 1e-9);
  EXPECT_NEAR(BestOf(grid, RideMetric::kTravel).volts, 2.25, 1e-9);

  // A controlled run: body acc 0.9, tyre load 725 N (<= only for |V - 1.6| <= 0.5).
  RidePoint c;
  c.body_accel_rms = 0.9;
  c.body_accel_wk_rms = 0.55;
  c.tyre_load_rms_n = 725.0;
  c.travel_rms_cm = 1.5;
  const PassiveComparison cmp = Compare(grid, c);
  EXPECT_NEAR(cmp.improvement[0], 10.0, 1e-9);                        // (1 - 0.9) / 1
  EXPECT_NEAR(cmp.improvement[1], 100.0 * (0.5 - 0.55) / 0.5, 1e-9);  // worse: negative
  ASSERT_TRUE(cmp.comfort_at_holding.has_value());
  EXPECT_NEAR(cmp.comfort_at_holding->volts, 1.10, 1e-9);  // the lowest V with tyre <= 725
  EXPECT_NEAR(cmp.comfort_at_holding->value, 1.0625, 1e-9);
  EXPECT_NEAR(*cmp.comfort_at_holding_improvement, 100.0 * (1.0625 - 0.9) / 1.0625, 1e-9);
  // The Wk-weighted figure at equal road holding: (V - 0.4)^2 + 0.5 over V in [1.1, 2.1].
  ASSERT_TRUE(cmp.wk_at_holding.has_value());
  EXPECT_NEAR(cmp.wk_at_holding->volts, 1.10, 1e-9);
  EXPECT_NEAR(cmp.wk_at_holding->value, 0.99, 1e-9);
  EXPECT_NEAR(*cmp.wk_at_holding_improvement, 100.0 * (0.99 - 0.55) / 0.99, 1e-9);
  // Below every passive tyre load: no comparison at equal road holding.
  c.tyre_load_rms_n = 650.0;
  EXPECT_FALSE(Compare(grid, c).comfort_at_holding.has_value());
  EXPECT_FALSE(Compare(grid, c).comfort_at_holding_improvement.has_value());
  EXPECT_FALSE(Compare(grid, c).wk_at_holding.has_value());
}

Scenario ShortQuarterCar() {
  Scenario s;
  std::string error;
  EXPECT_TRUE(LoadScenario(std::string(MRD_SOURCE_DIR) + "/hil/scenarios/quarter-car-skyhook.toml",
                           {"duration_s=4", "quarter_car.settle_s=1"}, &s, &error))
      << error;
  return s;
}

// The real plant: every constant setting runs on the same road; two runs agree bit for bit;
// the 0 V point is the plant's own constant-voltage run; Wk is below the unweighted RMS
// (the weighting is below 1 over most of the body's band) and positive.
TEST(PassiveGridTest, QuarterCarGridIsDeterministicAndScored) {
  const Scenario s = ShortQuarterCar();
  std::size_t calls = 0;
  const auto grid = RunPassiveGrid(s, 0.75, [&](std::size_t i, std::size_t n) {
    ++calls;
    EXPECT_EQ(n, 4u);
    EXPECT_EQ(i, calls);
    return true;
  });
  ASSERT_EQ(grid.size(), 4u);  // 0, 0.75, 1.5, 2.25
  EXPECT_EQ(calls, 4u);
  const auto again = RunPassiveGrid(s, 0.75);
  for (std::size_t i = 0; i < grid.size(); ++i) {
    EXPECT_EQ(grid[i].body_accel_rms, again[i].body_accel_rms);
    EXPECT_EQ(grid[i].body_accel_wk_rms, again[i].body_accel_wk_rms);
    EXPECT_EQ(grid[i].tyre_load_rms_n, again[i].tyre_load_rms_n);
    EXPECT_GT(grid[i].body_accel_wk_rms, 0.0);
    EXPECT_LT(grid[i].body_accel_wk_rms, grid[i].body_accel_rms);
    EXPECT_EQ(grid[i].samples, 3000u);
  }
  QuarterCarPlant plant = MakeQuarterCar(s);
  const RideMetrics off = RunConstantVoltage(&plant, 0.0, s.duration_s, s.ride_settle_s);
  EXPECT_EQ(grid[0].body_accel_rms, off.body_accel_rms());
  EXPECT_EQ(grid[0].tyre_load_rms_n, off.tyre_load_rms_n());
  // More damping, less travel: the travel RMS falls along the grid.
  EXPECT_GT(grid[0].travel_rms_cm, grid[3].travel_rms_cm);
  EXPECT_TRUE(RunPassiveGrid(s, 0.0).empty());
  EXPECT_TRUE(RunPassiveGrid(s, 0.75, [](std::size_t i, std::size_t) { return i < 2; }).empty());
}

}  // namespace
}  // namespace mrd::hil
