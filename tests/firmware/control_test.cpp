// Velocity estimation, control laws and the watchdog.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "mrd/firmware/control_law.hpp"
#include "mrd/firmware/velocity.hpp"
#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {
namespace {

// The filter computes in Real (float with MRD_REAL=float): inputs are rounded to it.
Real R(double x) { return static_cast<Real>(x); }

TEST(DisplacementDifferentiatorTest, RampGivesItsSlopeExactly) {
  DisplacementDifferentiator d;
  ASSERT_TRUE(d.Configure(30.0));
  EXPECT_EQ(d.Update(0, R(1e-3)), 0);  // first sample primes the filter
  double v = 0.0;
  for (int k = 1; k <= 2000; ++k) v = d.Update(R(5.0 * k * 1e-3), R(1e-3));  // 5 cm/s
  // Exact in exact arithmetic; x <= 10 cm and dt rounded to Real put up to about 2 ulp(10) / dt
  // into each difference quotient (double: 4e-12 cm/s; float: 4e-3 cm/s), plus the rounding of
  // dt itself (relative eps).
  const double eps = std::numeric_limits<Real>::epsilon();
  EXPECT_NEAR(v, 5.0, 1e-9 + 2.0 * 10.0 * eps / 1e-3 + 5.0 * eps);
}

TEST(DisplacementDifferentiatorTest, SineAtCutoffIsAttenuatedByFirstOrderGain) {
  DisplacementDifferentiator d;
  ASSERT_TRUE(d.Configure(20.0));
  const double f = 20.0, dt = 1e-4, w = 2.0 * std::numbers::pi * f;
  double peak = 0.0;
  for (int k = 0; k < 20000; ++k) {
    const double v = d.Update(R(std::sin(w * k * dt)), R(dt));
    if (k > 10000) peak = std::max(peak, std::fabs(v));
  }
  EXPECT_NEAR(peak / w, 1.0 / std::sqrt(2.0), 0.01);  // |H| / w = 1/sqrt(2) at the cut-off
}

TEST(DisplacementDifferentiatorTest, IgnoresInvalidSamplesAndSettings) {
  DisplacementDifferentiator d;
  EXPECT_FALSE(d.Configure(0.0));
  EXPECT_FALSE(d.Configure(std::nan("")));
  d.Update(0, R(1e-3));
  const Real v = d.Update(R(0.01), R(1e-3));
  EXPECT_EQ(d.Update(std::numeric_limits<Real>::quiet_NaN(), R(1e-3)), v);
  EXPECT_EQ(d.Update(R(0.02), 0), v);
}

TEST(ControlLawTest, ForceTrackingClampsDemand) {
  ControlLaw law;
  ControlLawConfig c;
  c.force_limit = 1000.0;
  law.Configure(c, 0.0, 2.25);
  EXPECT_EQ(law.Update({1.0, 400.0, 0.0}).value, 400.0);
  EXPECT_EQ(law.Update({1.0, 4000.0, 0.0}).value, 1000.0);
  EXPECT_EQ(law.Update({1.0, -4000.0, 0.0}).value, -1000.0);
  EXPECT_TRUE(law.Update({1.0, 0.0, 0.0}).is_force);
}

TEST(ControlLawTest, ConstantVoltage) {
  ControlLaw law;
  ControlLawConfig c;
  c.mode = ControlMode::kConstantVoltage;
  c.constant_voltage = 2.25;
  law.Configure(c, 0.0, 2.25);
  const ControlOutput out = law.Update({-3.0, 0.0, 0.0});
  EXPECT_FALSE(out.is_force);
  EXPECT_EQ(out.value, 2.25);
  EXPECT_FALSE(c.IsValid(0.0, 2.0));  // above E_max
}

TEST(ControlLawTest, TwoStateSkyhookSwitchesOnSignOfProduct) {
  ControlLaw law;
  ControlLawConfig c;
  c.mode = ControlMode::kSkyhookOnOff;
  law.Configure(c, 0.0, 2.0);
  EXPECT_EQ(law.Update({3.0, 0.0, 1.0}).value, 2.0);
  EXPECT_EQ(law.Update({-3.0, 0.0, -1.0}).value, 2.0);
  EXPECT_EQ(law.Update({3.0, 0.0, -1.0}).value, 0.0);
  EXPECT_EQ(law.Update({0.0, 0.0, 1.0}).value, 0.0);
}

TEST(ControlLawTest, ContinuousSkyhookDemandsGainTimesBodyVelocityWhenDissipative) {
  ControlLaw law;
  ControlLawConfig c;
  c.mode = ControlMode::kSkyhookContinuous;
  c.skyhook_gain = 50.0;
  law.Configure(c, 0.0, 2.25);
  ControlOutput out = law.Update({3.0, 0.0, 2.0});
  EXPECT_TRUE(out.is_force);
  EXPECT_EQ(out.value, 100.0);
  EXPECT_EQ(law.Update({-3.0, 0.0, 2.0}).value, 0.0);
}

TEST(WatchdogTest, TripsAtOnceAndRecoversAfterCleanPeriods) {
  Watchdog w;
  w.Configure({5'000'000, 3});
  w.Reset();
  const auto bus = Watchdog::Bit(FaultCause::kBusFault);
  for (int i = 0; i < 3; ++i) w.Update(0);
  EXPECT_FALSE(w.safe());
  EXPECT_TRUE(w.Update(bus));
  EXPECT_TRUE(w.Update(0));
  EXPECT_TRUE(w.Update(0));
  EXPECT_FALSE(w.Update(0));  // third clean period
  EXPECT_EQ(w.counters().trips[static_cast<std::size_t>(FaultCause::kBusFault)], 1U);
  EXPECT_EQ(w.counters().active_periods[static_cast<std::size_t>(FaultCause::kBusFault)], 1U);
  EXPECT_EQ(w.counters().entries, 1U);
}

TEST(WatchdogTest, CountsEachCauseSeparately) {
  Watchdog w;
  w.Configure({});
  w.Reset();
  const auto stale = Watchdog::Bit(FaultCause::kStaleSensor);
  const auto line = Watchdog::Bit(FaultCause::kFaultLine);
  w.Update(stale);
  w.Update(stale | line);
  w.Update(line);
  w.Update(0);
  w.Update(stale);
  const auto& c = w.counters();
  EXPECT_EQ(c.trips[static_cast<std::size_t>(FaultCause::kStaleSensor)], 2U);
  EXPECT_EQ(c.active_periods[static_cast<std::size_t>(FaultCause::kStaleSensor)], 3U);
  EXPECT_EQ(c.trips[static_cast<std::size_t>(FaultCause::kFaultLine)], 1U);
  EXPECT_EQ(c.active_periods[static_cast<std::size_t>(FaultCause::kFaultLine)], 2U);
  EXPECT_EQ(c.trips[static_cast<std::size_t>(FaultCause::kNonFinite)], 0U);
  EXPECT_STREQ(FaultCauseName(FaultCause::kDriverFault), "driver_fault");
}

}  // namespace
}  // namespace mrd::firmware

namespace mrd::firmware {
namespace {

// law "open-loop": the demand input is a voltage command in mV, passed through as a voltage
// (the controller clamps it to [E_min, E_max]); it needs a fresh demand like law "force".
TEST(ControlLawOpenLoop, PassesTheDemandThroughAsVolts) {
  ControlLawConfig c;
  c.mode = ControlMode::kOpenLoop;
  ASSERT_TRUE(c.IsValid(0.0, 2.25));
  ControlLaw law;
  law.Configure(c, 0.0, 2.25);
  EXPECT_TRUE(law.needs_demand());
  EXPECT_FALSE(law.needs_body_velocity());
  const ControlOutput out = law.Update({Real(5), Real(1250), Real(0)});
  EXPECT_FALSE(out.is_force);
  EXPECT_NEAR(static_cast<double>(out.value), 1.25, 1e-6);
  EXPECT_STREQ(ControlModeName(ControlMode::kOpenLoop), "open-loop");
}

}  // namespace
}  // namespace mrd::firmware
