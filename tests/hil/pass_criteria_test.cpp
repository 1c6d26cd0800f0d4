// A scenario's pass criteria against their baselines (run_scores.cpp EvaluatePass), on made-up
// figures: the ride criterion (body_accel_below_passive) is judged against the BETTER of the
// two passive cases, strictly, whichever of the two that is; the tyre load against passive-off;
// the structure's peaks against passive-on (not above); the absolute limits at their bounds.
// Then the figures' way into the sweep (ScoresOf: off is off, on is on) and each [pass] key
// setting its own criterion.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "mrd/hil/run/run.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/hil/study/sweep.hpp"
#include "run/run_internal.hpp"

namespace mrd::hil {
namespace {

// A quarter-car run's ride figures: body acceleration RMS [m/s^2] of the run and its twins.
RunResult Ride(double controlled, double off, double on) {
  RunResult r;
  r.commands = 1000;
  r.ride = RideScores{};
  r.ride->controlled.samples = r.ride->passive_off.samples = r.ride->passive_on.samples = 1000;
  r.ride->controlled.body_accel_rms = controlled;
  r.ride->passive_off.body_accel_rms = off;
  r.ride->passive_on.body_accel_rms = on;
  return r;
}

// Pass and failures of scenario s on r.
RunResult Judge(const Scenario& s, RunResult r) {
  EvaluatePass(s, &r);
  return r;
}

bool Mentions(const RunResult& r, const std::string& text) {
  for (const std::string& f : r.failures) {
    if (f.find(text) != std::string::npos) return true;
  }
  return false;
}

Scenario RideScenario() {
  Scenario s;
  s.body_accel_below_passive = true;
  return s;
}

TEST(PassCriteriaTest, RideBelowTheBetterPassiveCasePasses) {
  const Scenario s = RideScenario();
  EXPECT_TRUE(Judge(s, Ride(0.9, 1.2, 1.0)).pass);  // passive-on the better
  EXPECT_TRUE(Judge(s, Ride(0.9, 1.0, 1.2)).pass);  // passive-off the better
}

// Between the two passive cases: better than one, worse than the better one: a fail, with the
// better case's figure in the message.
TEST(PassCriteriaTest, RideBetweenThePassiveCasesFails) {
  const Scenario s = RideScenario();
  for (const RunResult& r : {Judge(s, Ride(1.1, 1.2, 1.0)), Judge(s, Ride(1.1, 1.0, 1.2))}) {
    EXPECT_FALSE(r.pass);
    ASSERT_EQ(r.failures.size(), 1u);
    EXPECT_EQ(r.failures[0], "body acceleration RMS 1.1 m/s^2 not below the better passive case 1");
  }
  // Worse than both: a fail too.
  EXPECT_FALSE(Judge(s, Ride(1.3, 1.2, 1.0)).pass);
}

// Equal to the better passive case is no improvement: a fail (strictly below).
TEST(PassCriteriaTest, RideEqualToTheBetterPassiveCaseFails) {
  const Scenario s = RideScenario();
  EXPECT_FALSE(Judge(s, Ride(1.0, 1.2, 1.0)).pass);
  EXPECT_FALSE(Judge(s, Ride(1.0, 1.0, 1.2)).pass);
  // The criterion off: the same figures pass.
  EXPECT_TRUE(Judge(Scenario{}, Ride(1.3, 1.2, 1.0)).pass);
}

TEST(PassCriteriaTest, RideWithoutFiguresFails) {
  const Scenario s = RideScenario();
  RunResult r = Ride(0.9, 1.2, 1.0);
  r.ride->controlled.samples = 0;
  r = Judge(s, r);
  EXPECT_FALSE(r.pass);
  EXPECT_TRUE(Mentions(r, "no ride figures")) << r.failures.size();
}

// Tyre load against passive-off's, strictly; passive-on's does not count.
TEST(PassCriteriaTest, TyreLoadIsJudgedAgainstPassiveOff) {
  Scenario s;
  s.tyre_load_below_passive_off = true;
  RunResult r = Ride(1.0, 1.0, 1.0);
  r.ride->passive_off.tyre_load_rms_n = 800.0;
  r.ride->passive_on.tyre_load_rms_n = 600.0;
  r.ride->controlled.tyre_load_rms_n = 700.0;  // below off, above on: passes
  EXPECT_TRUE(Judge(s, r).pass);
  r.ride->passive_off.tyre_load_rms_n = 600.0;
  r.ride->passive_on.tyre_load_rms_n = 800.0;  // below on, above off: fails
  const RunResult above = Judge(s, r);
  EXPECT_FALSE(above.pass);
  EXPECT_TRUE(Mentions(above, "tyre load RMS 700 N not below passive-off's 600"));
  r.ride->controlled.tyre_load_rms_n = 600.0;  // equal: fails
  EXPECT_FALSE(Judge(s, r).pass);
}

// A structure run's peaks: drift [cm] and absolute floor acceleration [cm/s^2] per floor.
RunResult Structure(double drift, double drift_on, double drift_off, double accel, double accel_on,
                    double accel_off) {
  RunResult r;
  r.commands = 1000;
  r.structure = StructureScores{};
  StructureScores& st = *r.structure;
  st.controlled.samples = st.passive_on.samples = st.passive_off.samples = 1000;
  st.controlled.peak_d_cm[1] = drift;
  st.passive_on.peak_d_cm[2] = drift_on;
  st.passive_off.peak_d_cm[0] = drift_off;
  st.controlled.peak_xa_cm_s2[2] = accel;
  st.passive_on.peak_xa_cm_s2[0] = accel_on;
  st.passive_off.peak_xa_cm_s2[1] = accel_off;
  return r;
}

// The largest peak over the floors, against passive-on's (not above; passive-off's does not
// count).
TEST(PassCriteriaTest, StructurePeaksAreJudgedAgainstPassiveOn) {
  Scenario s;
  s.peak_drift_below_passive_on = true;
  s.peak_accel_below_passive_on = true;
  EXPECT_TRUE(Judge(s, Structure(1.0, 1.2, 0.5, 300.0, 350.0, 100.0)).pass);
  EXPECT_TRUE(Judge(s, Structure(1.2, 1.2, 0.5, 350.0, 350.0, 100.0)).pass);  // equal: passes
  const RunResult drift = Judge(s, Structure(1.3, 1.2, 2.0, 300.0, 350.0, 400.0));
  EXPECT_FALSE(drift.pass);
  ASSERT_EQ(drift.failures.size(), 1u);
  EXPECT_TRUE(Mentions(drift, "peak drift 1.3 cm above passive-on's 1.2"));
  const RunResult accel = Judge(s, Structure(1.0, 1.2, 2.0, 360.0, 350.0, 400.0));
  EXPECT_FALSE(accel.pass);
  ASSERT_EQ(accel.failures.size(), 1u);
  EXPECT_TRUE(Mentions(accel, "peak floor acceleration 360 cm/s^2 above passive-on's 350"));
}

TEST(PassCriteriaTest, AbsoluteLimitsHoldAtTheirBounds) {
  Scenario s;
  s.max_peak_force_n = 1000.0;
  RunResult r = Structure(1.0, 1.2, 0.5, 300.0, 350.0, 100.0);
  r.structure->controlled.peak_force_n = 1000.0;
  EXPECT_TRUE(Judge(s, r).pass);
  r.structure->controlled.peak_force_n = 1000.5;
  EXPECT_FALSE(Judge(s, r).pass);

  Scenario t;
  t.max_error_reachable = 0.2;
  t.max_error_all = 0.3;
  RunResult k;
  k.commands = 1000;
  k.tracking.steps = k.tracking.reachable_steps = 1000;
  k.tracking.reachable_share = 1.0;
  k.tracking.all_scored = k.tracking.reachable_scored = true;
  k.tracking.error_reachable = 0.2;
  k.tracking.error_all = 0.3;
  EXPECT_TRUE(Judge(t, k).pass);
  k.tracking.error_reachable = 0.2001;
  EXPECT_FALSE(Judge(t, k).pass);
  k.tracking.error_reachable = 0.2;
  k.tracking.error_all = 0.3001;
  EXPECT_FALSE(Judge(t, k).pass);

  Scenario g;
  g.max_missed_grants = 2;
  RunResult m;
  m.commands = 1000;
  m.clock = "lockstep";
  m.missed_grants = 2;
  EXPECT_TRUE(Judge(g, m).pass);
  m.missed_grants = 3;
  EXPECT_FALSE(Judge(g, m).pass);
}

// The sweep's figures: passive-off's into the off column, passive-on's into the on column.
TEST(PassCriteriaTest, SweepScoresKeepEachPassiveCaseInItsOwnColumn) {
  RunResult r = Ride(0.9, 1.2, 1.0);
  r.ride->controlled.travel_rms_cm = 2.0;
  r.ride->controlled.tyre_load_rms_n = 700.0;
  const SweepScores s = ScoresOf(r);
  EXPECT_TRUE(s.ride);
  EXPECT_EQ(s.body_accel_rms, 0.9);
  EXPECT_EQ(s.body_accel_off, 1.2);
  EXPECT_EQ(s.body_accel_on, 1.0);
  EXPECT_EQ(s.travel_rms_cm, 2.0);
  EXPECT_EQ(s.tyre_load_rms_n, 700.0);
}

// Each [pass] flag sets its own criterion and no other: on the quarter car for the ride flags,
// on the structure for the peak flags (each plant refuses the other's), the others set false.
TEST(PassCriteriaTest, EachPassKeySetsItsOwnCriterion) {
  const std::string dir = std::string(MRD_SOURCE_DIR) + "/hil/scenarios/";
  struct Key {
    const char* name;
    bool Scenario::*field;
    const char* scenario;
  };
  const Key keys[] = {
      {"body_accel_below_passive", &Scenario::body_accel_below_passive, "quarter-car-skyhook"},
      {"tyre_load_below_passive_off", &Scenario::tyre_load_below_passive_off,
       "quarter-car-skyhook"},
      {"peak_drift_below_passive_on", &Scenario::peak_drift_below_passive_on,
       "structure-clipped-optimal"},
      {"peak_accel_below_passive_on", &Scenario::peak_accel_below_passive_on,
       "structure-clipped-optimal"}};
  for (const Key& k : keys) {
    std::vector<std::string> sets;
    for (const Key& other : keys) {
      if (std::string(other.scenario) == k.scenario) {
        sets.push_back(std::string("pass.") + other.name + (&other == &k ? "=true" : "=false"));
      }
    }
    Scenario s;
    std::string error;
    ASSERT_TRUE(LoadScenario(dir + k.scenario + ".toml", sets, &s, &error))
        << k.name << ": " << error;
    for (const Key& other : keys) EXPECT_EQ(s.*other.field, &other == &k) << k.name;
  }
}

}  // namespace
}  // namespace mrd::hil
