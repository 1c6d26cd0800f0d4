// `--set` overrides of a scenario and the sweep grid (labels hil, observe): overrides change
// what is read, bad ones are refused naming the --set, ranges expand and bad ones are refused.
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/hil/study/sweep.hpp"

namespace {

using mrd::hil::LoadScenario;
using mrd::hil::ParseSweepGrid;
using mrd::hil::Scenario;
using mrd::hil::SweepGrid;

const std::string kSkyhook = MRD_SOURCE_DIR "/hil/scenarios/quarter-car-skyhook.toml";

TEST(ScenarioSet, OverridesChangeTheScenario) {
  Scenario plain, set;
  std::string error;
  ASSERT_TRUE(LoadScenario(kSkyhook, &plain, &error)) << error;
  ASSERT_TRUE(
      LoadScenario(kSkyhook,
                   {"duration_s=5", "control.skyhook_gain=40", "pass.max_error_reachable=0.2",
                    "road.class=D", "quarter_car.settle_s=1.5"},
                   &set, &error))
      << error;
  EXPECT_DOUBLE_EQ(plain.duration_s, 25.0);
  EXPECT_DOUBLE_EQ(plain.skyhook_gain, 60.0);
  EXPECT_DOUBLE_EQ(set.duration_s, 5.0);  // an integer TOML value for a number key
  EXPECT_DOUBLE_EQ(set.skyhook_gain, 40.0);
  ASSERT_TRUE(set.max_error_reachable.has_value());
  EXPECT_DOUBLE_EQ(*set.max_error_reachable, 0.2);
  EXPECT_EQ(set.road.road_class, mrd::RoadClass::kD);
  EXPECT_DOUBLE_EQ(set.ride_settle_s, 1.5);
  EXPECT_EQ(set.car.sprung_mass_kg, plain.car.sprung_mass_kg);  // the rest as in the file
  // A bare word is a string; a quoted one too; the last --set of a key wins.
  ASSERT_TRUE(
      LoadScenario(kSkyhook, {"control.law=passive-on", "name=\"x y\"", "name=z"}, &set, &error))
      << error;
  EXPECT_EQ(set.law, "passive-on");
  EXPECT_EQ(set.name, "z");
}

TEST(ScenarioSet, BadOverridesAreRefusedNamingThem) {
  struct Case {
    std::string set, why;
  };
  const std::vector<Case> cases = {
      {"control.skyhook_gain=abc",
       "--set control.skyhook_gain=abc: 'skyhook_gain' must be a number"},
      {"control.skyhook_gain=-1", "--set control.skyhook_gain=-1: 'skyhook_gain' must be a number"},
      {"control.gain=1", "--set control.gain=1: unknown key 'gain' in [control]"},
      {"nosuch.key=1", "--set nosuch.key=1: unknown section [nosuch]"},
      {"road.seed=1.5", "--set road.seed=1.5: 'seed' must be an integer"},
      {"control.law=magic", "--set control.law=magic: law must be"},
      {"duration_s", "--set duration_s: expected KEY=VALUE"},
      {"duration_s=", "--set duration_s=: no VALUE"},
      {"=3", "--set =3: KEY must be a dotted path"},
      {"control..law=x", "--set control..law=x: KEY must be a dotted path"},
      {"a b=1", "KEY must be a dotted path"},
      {"control=1", "--set control=1: [control] must be a table"},
      // A line break cannot smuggle in a second key: the whole VALUE is one string.
      {"duration_s=1\nduration_s = 2", "'duration_s' must be a number"},
  };
  for (const Case& c : cases) {
    Scenario s;
    std::string error;
    EXPECT_FALSE(LoadScenario(kSkyhook, {c.set}, &s, &error)) << c.set;
    EXPECT_NE(error.find(c.why), std::string::npos) << c.set << " -> " << error;
  }
  {
    Scenario s;
    std::string error;
    ASSERT_TRUE(LoadScenario(kSkyhook, {"name=x\nduration_s = 1"}, &s, &error)) << error;
    EXPECT_EQ(s.name, "x\nduration_s = 1");
    EXPECT_DOUBLE_EQ(s.duration_s, 25.0);
  }
  // The file's own checks still apply to the overridden scenario.
  Scenario s;
  std::string error;
  EXPECT_FALSE(LoadScenario(kSkyhook, {"duration_s=1"}, &s, &error));
  EXPECT_NE(error.find("settle_s must be shorter than duration_s"), std::string::npos) << error;
}

TEST(SweepGrid, RangesExpandIntoTheProduct) {
  SweepGrid g;
  std::string error;
  ASSERT_TRUE(ParseSweepGrid({"control.skyhook_gain=10:30:10", "duration_s=3", "road.seed=1:2:1"},
                             &g, &error))
      << error;
  ASSERT_EQ(g.axes.size(), 2U);
  EXPECT_EQ(g.fixed, std::vector<std::string>{"duration_s=3"});
  EXPECT_EQ(g.axes[0].values, (std::vector<std::string>{"10", "20", "30"}));
  const auto points = g.Points();
  ASSERT_EQ(points.size(), 6U);
  EXPECT_EQ(points[0], (std::vector<std::string>{"control.skyhook_gain=10", "road.seed=1"}));
  EXPECT_EQ(points[1], (std::vector<std::string>{"control.skyhook_gain=20", "road.seed=1"}));
  EXPECT_EQ(points[5], (std::vector<std::string>{"control.skyhook_gain=30", "road.seed=2"}));
  // Decimal steps land on their decimal values; TO is included within rounding; downwards.
  ASSERT_TRUE(ParseSweepGrid({"e_max=0.1:0.3:0.1"}, &g, &error)) << error;
  EXPECT_EQ(g.axes[0].values, (std::vector<std::string>{"0.1", "0.2", "0.3"}));
  ASSERT_TRUE(ParseSweepGrid({"e_max=2:1:-0.5"}, &g, &error)) << error;
  EXPECT_EQ(g.axes[0].values, (std::vector<std::string>{"2", "1.5", "1"}));
  ASSERT_TRUE(ParseSweepGrid({"e_max=1:1.9:0.5"}, &g, &error)) << error;
  EXPECT_EQ(g.axes[0].values, (std::vector<std::string>{"1", "1.5"}));
  ASSERT_TRUE(ParseSweepGrid({"e_max=1:1:1"}, &g, &error)) << error;
  EXPECT_EQ(g.axes[0].values, (std::vector<std::string>{"1"}));
  // A quoted value with ':' is a fixed string, not a range.
  ASSERT_TRUE(ParseSweepGrid({"name=\"a:b:c\"", "e_max=1:2:1"}, &g, &error)) << error;
  EXPECT_EQ(g.fixed.size(), 1U);
}

TEST(SweepGrid, BadRangesAreRefused) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"control.skyhook_gain=10:120:0", "STEP must not be 0"},
      {"control.skyhook_gain=120:10:10", "STEP must be negative"},
      {"control.skyhook_gain=10:120:-10", "STEP must be positive"},
      {"control.skyhook_gain=a:120:10", "finite numbers"},
      {"control.skyhook_gain=10:120:", "finite numbers"},
      {"control.skyhook_gain=10:nan:1", "finite numbers"},
      {"control.skyhook_gain=10:120", "a range is FROM:TO:STEP"},
      {"control.skyhook_gain=1:2:3:4", "a range is FROM:TO:STEP"},
      {"control.skyhook_gain=0:1e6:1", "more than 1000 points"},
      {"nokey", "expected KEY=VALUE"},
  };
  for (const auto& [set, why] : cases) {
    SweepGrid g;
    std::string error;
    EXPECT_FALSE(ParseSweepGrid({set}, &g, &error)) << set;
    EXPECT_NE(error.find("--set " + set), std::string::npos) << error;
    EXPECT_NE(error.find(why), std::string::npos) << set << " -> " << error;
  }
  SweepGrid g;
  std::string error;
  EXPECT_FALSE(ParseSweepGrid({"duration_s=3"}, &g, &error));
  EXPECT_NE(error.find("at least one --set KEY=FROM:TO:STEP"), std::string::npos) << error;
  EXPECT_FALSE(ParseSweepGrid({"e_max=1:2:1", "e_max=1:3:1"}, &g, &error));
  EXPECT_NE(error.find("swept twice"), std::string::npos) << error;
  // The product counts: 40 x 40 points > 1000.
  EXPECT_FALSE(ParseSweepGrid({"e_max=1:40:1", "duration_s=1:40:1"}, &g, &error));
  EXPECT_NE(error.find("more than 1000 points"), std::string::npos) << error;
}

TEST(SweepGrid, BestPointPrefersPassingThenLowestScore) {
  std::vector<mrd::hil::SweepScores> rows(3);
  for (auto& r : rows) r.ride = true;
  rows[0].body_accel_rms = 1.0;  // fails
  rows[1].body_accel_rms = 1.3;
  rows[1].pass = true;
  rows[2].body_accel_rms = 1.2;
  rows[2].pass = true;
  EXPECT_EQ(mrd::hil::BestPoint(rows), 2U);
  SweepGrid g;
  std::string error;
  ASSERT_TRUE(ParseSweepGrid({"control.skyhook_gain=10:30:10"}, &g, &error));
  const std::string csv = mrd::hil::SweepCsv(g, rows);
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "control.skyhook_gain,pass,invariant_violations,error_all,error_reachable,"
            "reachable_share,body_accel_rms,travel_rms_cm,tyre_load_rms_n,body_accel_rms_off,body_"
            "accel_rms_on,"
            "table,plant");
  // A quarter car has no tracking error: those cells stay empty.
  EXPECT_NE(csv.find("\n30,1,0,,,,1.2,"), std::string::npos) << csv;
  rows[2].body_accel_off = 1.5;  // 20 % better than passive-off
  rows[2].body_accel_on = 1.0;   // 20 % worse than passive-on
  const std::string table = mrd::hil::SweepTable(g, rows);
  EXPECT_NE(table.find("<- best"), std::string::npos);
  EXPECT_NE(table.find("better_than_off"), std::string::npos) << table;
  EXPECT_NE(table.find(" 20.0% "), std::string::npos) << table;
  EXPECT_NE(table.find(" -20.0%"), std::string::npos) << table;
}

}  // namespace
