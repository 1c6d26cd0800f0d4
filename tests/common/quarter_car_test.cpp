// Quarter car (common/sim/include/mrd/sim/quarter_car.hpp): equilibrium, outputs, voltage
// handling, integration convergence, determinism, stroke on class C, lift-off, no allocation.
// The allocation counter (tests/support/alloc_counter.hpp) replaces the allocator of this
// executable.
#include "mrd/sim/quarter_car.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <limits>

#include "support/alloc_counter.hpp"

namespace mrd {
namespace {

constexpr double kPeriod = 1e-3;  // [s]

TEST(QuarterCarTest, RestsInEquilibriumOnAStillRoadWithEitherPreset) {
  // Speed 0: the road under the tyre never changes. The Spencer 1997 preset has an
  // accumulator force -k1 x0 = -71.5 N at x = 0: balanced by the preload, so nothing moves.
  for (const SpencerParams& d : {SpencerParams::Paper(), SpencerParams::Spencer1997()}) {
    QuarterCarParams car;
    car.speed_m_s = 0.0;
    QuarterCarPlant plant(d, car, RoadParams{}, kPeriod);
    const double z0 = plant.state().zs;
    for (int k = 0; k < 500; ++k) plant.Step(k < 250 ? 0.0 : 2.25);
    EXPECT_NEAR(plant.state().zs, z0, 1e-12);
    EXPECT_NEAR(plant.Detail().body_accel, 0.0, 1e-9);
    EXPECT_NEAR(plant.Detail().tyre_load_n, 0.0, 1e-6);
    EXPECT_NEAR(plant.Detail().travel_cm, 0.0, 1e-9);
    EXPECT_NEAR(plant.state().d.u, 2.25, 1e-6);  // the field filter settled (eta 190..251 /s)
  }
}

TEST(QuarterCarTest, SampleFieldsAreTheDamperSideOfTheCar) {
  QuarterCarParams car;
  QuarterCarPlant plant(SpencerParams::Paper(), car, RoadParams{}, kPeriod);
  for (int k = 0; k < 3000; ++k) plant.Step(1.0);
  const QuarterCarSample& q = plant.Detail();
  const QuarterCarPlant::State& s = plant.state();
  EXPECT_DOUBLE_EQ(q.plant.t_s, 3.0);
  EXPECT_DOUBLE_EQ(q.distance_m, 60.0);
  EXPECT_NEAR(q.plant.x, car.motion_ratio * q.travel_cm, 1e-12);
  EXPECT_NEAR(q.plant.v, 100.0 * car.motion_ratio * (s.vs - s.vu), 1e-12);
  EXPECT_DOUBLE_EQ(q.plant.body_velocity, 100.0 * s.vs);
  EXPECT_EQ(q.plant.demand, 0.0);
  EXPECT_NEAR(q.road_m, plant.road().Height(60.0), 1e-12);
  // Body: ms a = -ks d - r (f - f0), with f0 = 0 for the paper preset (x0 = 0).
  const double expect =
      (-car.spring_n_per_m * (s.zs - s.zu) - car.motion_ratio * q.plant.force) / car.sprung_mass_kg;
  EXPECT_NEAR(q.body_accel, expect, 1e-9);
  EXPECT_NEAR(q.tyre_load_n, car.tyre_n_per_m * (q.road_m - s.zu), 1e-9);
  EXPECT_EQ(plant.Sample().x, q.plant.x);
}

TEST(QuarterCarTest, VoltageIsClampedAndNonFiniteMeansZero) {
  QuarterCarParams car;
  QuarterCarPlant a(SpencerParams::Paper(), car, RoadParams{}, kPeriod);
  QuarterCarPlant b(SpencerParams::Paper(), car, RoadParams{}, kPeriod);
  for (int k = 0; k < 500; ++k) {
    a.Step(0.0);
    b.Step(k % 2 ? std::numeric_limits<double>::quiet_NaN() : -3.0);
  }
  EXPECT_EQ(a.state().zs, b.state().zs);
  EXPECT_EQ(a.Sample().force, b.Sample().force);
  for (int k = 0; k < 200; ++k) a.Step(100.0);
  EXPECT_NEAR(a.state().d.u, car.max_volts, 1e-6);
}

TEST(QuarterCarTest, ResetAndASecondPlantReproduceTheRun) {
  QuarterCarPlant a(SpencerParams::Paper(), QuarterCarParams{}, RoadParams{}, kPeriod);
  QuarterCarPlant b(SpencerParams::Paper(), QuarterCarParams{}, RoadParams{}, kPeriod);
  const auto volts = [](int k) { return 1.125 * (1.0 + std::sin(0.01 * k)); };
  for (int k = 0; k < 2000; ++k) a.Step(volts(k));
  const double zs = a.state().zs, f = a.Sample().force;
  a.Reset();
  EXPECT_EQ(a.steps(), 0u);
  for (int k = 0; k < 2000; ++k) {
    a.Step(volts(k));
    b.Step(volts(k));
  }
  EXPECT_EQ(a.state().zs, zs);
  EXPECT_EQ(a.Sample().force, f);
  EXPECT_EQ(b.state().zs, zs);
}

// 10 substeps (100 us) against 100: the ride figures agree to 1e-4 relative (the stiffest
// dynamics are the damper's hysteresis and the 11 Hz wheel hop).
TEST(QuarterCarTest, TenSubstepsAreConverged) {
  for (const double volts : {0.0, 2.25}) {
    QuarterCarParams coarse, fine;
    coarse.substeps = 10;
    fine.substeps = 100;
    QuarterCarPlant a(SpencerParams::Paper(), coarse, RoadParams{}, kPeriod);
    QuarterCarPlant b(SpencerParams::Paper(), fine, RoadParams{}, kPeriod);
    const RideMetrics ma = RunConstantVoltage(&a, volts, 5.0, 1.0);
    const RideMetrics mb = RunConstantVoltage(&b, volts, 5.0, 1.0);
    EXPECT_NEAR(ma.body_accel_rms() / mb.body_accel_rms(), 1.0, 1e-4) << volts;
    EXPECT_NEAR(ma.travel_rms_cm() / mb.travel_rms_cm(), 1.0, 1e-4) << volts;
    EXPECT_NEAR(ma.tyre_load_rms_n() / mb.tyre_load_rms_n(), 1.0, 1e-4) << volts;
  }
}

// The coupled step is classical RK4: halving the substep cuts the error against a fine
// reference by ~16 (fourth order); a lower-order scheme (e.g. a wrong stage) by ~4 or less.
// Smooth dynamics are needed to see the order (the Bouc-Wen term's |.| kinks at every velocity
// reversal cost RK4 its order), so the damper here is the Spencer model without hysteresis
// (alpha = A = gamma = beta = 0): linear and smooth, all 7 states still coupled.
TEST(QuarterCarTest, CoupledStepConvergesAtFourthOrder) {
  SpencerParams linear = SpencerParams::Paper();
  linear.alpha_a = linear.alpha_b = linear.A = linear.gamma = linear.beta = 0.0;
  const auto run = [&](int substeps) {
    QuarterCarParams car;
    car.substeps = substeps;
    QuarterCarPlant p(linear, car, RoadParams{}, kPeriod);
    for (int k = 0; k < 1000; ++k) p.Step(0.5);
    return p.state();
  };
  const QuarterCarPlant::State ref = run(400);
  const auto error = [&](int substeps) {
    const QuarterCarPlant::State s = run(substeps);
    return std::fabs(s.vs - ref.vs) + std::fabs(s.vu - ref.vu);  // [m/s]
  };
  const double e4 = error(4), e8 = error(8), e16 = error(16);
  std::printf("error after 1 s, 4/8/16 substeps: %.3g %.3g %.3g m/s (ratios %.1f %.1f)\n", e4, e8,
              e16, e4 / e8, e8 / e16);
  EXPECT_GT(e4 / e8, 10.0);
  EXPECT_GT(e8 / e16, 10.0);
}

// The default car on class C at 20 m/s keeps the suspension within a few cm and the wheel on
// the ground (the Spencer damper's stroke is a few cm; the damper moves 0.7 of the wheel).
TEST(QuarterCarTest, ClassCAtTwentyMetresPerSecondStaysWithinAFewCentimetres) {
  QuarterCarPlant plant(SpencerParams::Paper(), QuarterCarParams{}, RoadParams{}, kPeriod);
  for (const double volts : {0.0, 2.25}) {
    const RideMetrics m = RunConstantVoltage(&plant, volts, 20.0, 2.0);
    EXPECT_LT(m.max_travel_cm(), 6.0) << volts;
    EXPECT_GT(m.travel_rms_cm(), 0.3) << volts;  // the road does excite it
    EXPECT_LT(m.lift_off(), 20u) << volts;       // < 0.1 % of the samples
    EXPECT_EQ(m.count(), 18000u);
  }
}

TEST(QuarterCarTest, RoughRoadLiftsTheWheelAndTyreForceNeverPulls) {
  RoadParams road;
  road.road_class = RoadClass::kF;
  QuarterCarParams car;
  car.speed_m_s = 30.0;
  QuarterCarPlant plant(SpencerParams::Paper(), car, road, kPeriod);
  std::uint64_t airborne = 0;
  for (int k = 0; k < 5000; ++k) {
    plant.Step(2.25);
    EXPECT_GE(plant.Detail().tyre_load_n, -plant.static_tyre_load_n() - 1e-9);
    if (plant.Detail().airborne) ++airborne;
  }
  EXPECT_GT(airborne, 0u);
  EXPECT_TRUE(std::isfinite(plant.state().zs));
}

TEST(QuarterCarTest, ParametersAreValidated) {
  const char* reason = nullptr;
  QuarterCarParams p;
  EXPECT_TRUE(p.IsValid(&reason));
  p.motion_ratio = 1.5;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "motion_ratio");
  p = QuarterCarParams{};
  p.sprung_mass_kg = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "sprung_mass_kg");
  p = QuarterCarParams{};
  p.substeps = 0;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "substeps");
}

TEST(QuarterCarTest, StepAllocatesNothing) {
  QuarterCarPlant plant(SpencerParams::Paper(), QuarterCarParams{}, RoadParams{}, kPeriod);
  RideMetrics m;
  {
    test::ThreadAllocationGuard guard;
    ::operator delete(::operator new(8));  // the counter counts (a call, not elidable)
    guard.Stop();
    ASSERT_GE(guard.CountOn(gettid()), 1U);
  }
  test::ThreadAllocationGuard guard;
  for (int k = 0; k < 1000; ++k) {
    plant.Step(k % 3 == 0 ? 2.25 : 0.5);
    m.Add(plant.Detail());
  }
  plant.Reset();
  guard.Stop();
  EXPECT_EQ(guard.CountOn(gettid()), 0U) << "the plant allocated:\n" << guard.Report();
}

}  // namespace
}  // namespace mrd
