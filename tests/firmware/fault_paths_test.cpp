// Controller fault paths with hand-made sensor frames: each required signal alone stale or
// non-finite, plausibility limits on both signs, the displacement-derived velocity reaching
// the model.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "mrd/firmware/controller.hpp"
#include "mrd/sim/spencer_damper.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kMs = 1'000'000;  // [ns]
constexpr double kDt = 1e-3;             // [s]

// Every signal sampled at now_ns.
SensorFrame Fresh(std::int64_t now_ns, double v = 3.0, double x = 0.5, double demand = 200.0,
                  double body = 4.0) {
  SensorFrame f;
  f[Input::kVelocity] = {v, now_ns};
  f[Input::kDisplacement] = {x, now_ns};
  f[Input::kDemand] = {demand, now_ns};
  f[Input::kBodyVelocity] = {body, now_ns};
  f[Input::kForce] = {0.0, now_ns};
  return f;
}

ControllerOutput Update(Controller& c, const SensorFrame& f, std::int64_t now_ns) {
  return c.Update(f, IoStatus::kOk, false, now_ns, kDt);
}

constexpr std::uint32_t kStale = Watchdog::Bit(FaultCause::kStaleSensor);
constexpr std::uint32_t kNonFinite = Watchdog::Bit(FaultCause::kNonFinite);
constexpr std::uint32_t kImplausible = Watchdog::Bit(FaultCause::kImplausible);

TEST(ControllerFaultTest, SkyhookLawsEnterSafeStateWhenOnlyBodyVelocityIsStaleOrNaN) {
  for (const ControlMode mode : {ControlMode::kSkyhookOnOff, ControlMode::kSkyhookContinuous}) {
    SCOPED_TRACE(ControlModeName(mode));
    ControllerConfig config;
    config.law.mode = mode;
    config.watchdog.max_age_ns = 3 * kMs;
    Controller c;
    ASSERT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOk);
    std::int64_t t = 10 * kMs;
    ControllerOutput out = Update(c, Fresh(t), t);
    EXPECT_FALSE(out.safe);
    EXPECT_EQ(out.causes, 0U);

    t += kMs;
    SensorFrame f = Fresh(t);
    f[Input::kBodyVelocity].stamp_ns = t - 3 * kMs;  // exactly max_age: still fresh
    out = Update(c, f, t);
    EXPECT_FALSE(out.safe);

    t += kMs;
    f = Fresh(t);
    f[Input::kBodyVelocity].stamp_ns = t - 3 * kMs - 1;  // 1 ns older than max_age
    out = Update(c, f, t);
    EXPECT_TRUE(out.safe);
    EXPECT_EQ(out.causes, kStale);
    EXPECT_EQ(out.volts, config.safe_voltage);

    t += kMs;
    EXPECT_FALSE(Update(c, Fresh(t), t).safe);  // recovers after one clean period

    t += kMs;
    f = Fresh(t);
    f[Input::kBodyVelocity].value = std::numeric_limits<double>::quiet_NaN();
    out = Update(c, f, t);
    EXPECT_TRUE(out.safe);
    EXPECT_EQ(out.causes, kNonFinite);

    t += kMs;
    f = Fresh(t);
    f[Input::kBodyVelocity] = Stamped{};  // never sampled
    out = Update(c, f, t);
    EXPECT_TRUE(out.safe);
    EXPECT_EQ(out.causes & kStale, kStale);

    const auto& w = c.watchdog().counters();
    EXPECT_EQ(w.trips[static_cast<std::size_t>(FaultCause::kStaleSensor)], 2U);
    // NaN then never sampled (NaN too): one non-finite episode.
    EXPECT_EQ(w.trips[static_cast<std::size_t>(FaultCause::kNonFinite)], 1U);
  }
}

TEST(ControllerFaultTest, ForceTrackingIgnoresBodyVelocityButNotDemand) {
  ControllerConfig config;
  config.watchdog.max_age_ns = 3 * kMs;
  Controller c;
  ASSERT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOk);
  std::int64_t t = 10 * kMs;
  SensorFrame f = Fresh(t);
  f[Input::kBodyVelocity] = Stamped{};
  EXPECT_FALSE(Update(c, f, t).safe);
  t += kMs;
  f = Fresh(t);
  f[Input::kDemand].stamp_ns = t - 4 * kMs;
  EXPECT_EQ(Update(c, f, t).causes, kStale);
}

TEST(ControllerFaultTest, ConstantVoltageAcceptsTheRangeEndsAndNothingBeyond) {
  ControlLawConfig law;
  law.mode = ControlMode::kConstantVoltage;
  for (const double volts : {0.0, 2.25}) {  // passive-off and passive-on
    law.constant_voltage = volts;
    EXPECT_TRUE(law.IsValid(0.0, 2.25)) << volts;
  }
  law.constant_voltage = 2.2500001;
  EXPECT_FALSE(law.IsValid(0.0, 2.25));
  law.constant_voltage = -1e-9;
  EXPECT_FALSE(law.IsValid(0.0, 2.25));
}

TEST(ControllerFaultTest, NegativeVelocityBeyondLimitIsImplausible) {
  ControllerConfig config;
  config.velocity_limit = 100.0;
  Controller c;
  ASSERT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOk);
  std::int64_t t = 10 * kMs;
  EXPECT_FALSE(Update(c, Fresh(t, -99.0), t).safe);
  t += kMs;
  ControllerOutput out = Update(c, Fresh(t, -150.0), t);
  EXPECT_TRUE(out.safe);
  EXPECT_EQ(out.causes, kImplausible);
  t += kMs;
  EXPECT_FALSE(Update(c, Fresh(t, 99.0), t).safe);
  t += kMs;
  out = Update(c, Fresh(t, 150.0), t);
  EXPECT_EQ(out.causes, kImplausible);
}

TEST(ControllerFaultTest, NegativeDisplacementAndDerivedVelocityBeyondLimitsAreImplausible) {
  ControllerConfig config;
  config.velocity_source = VelocitySource::kDisplacement;
  config.velocity_limit = 100.0;
  config.displacement_limit = 10.0;
  for (const double sign : {-1.0, 1.0}) {
    SCOPED_TRACE(sign);
    Controller c;
    ASSERT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOk);
    std::int64_t t = 10 * kMs;
    EXPECT_FALSE(Update(c, Fresh(t, 0.0, 0.0), t).safe);
    t += kMs;
    EXPECT_FALSE(Update(c, Fresh(t, 0.0, 0.0), t).safe);
    // |x| 11 cm > 10 cm.
    t += kMs;
    ControllerOutput out = Update(c, Fresh(t, 0.0, sign * 11.0), t);
    EXPECT_EQ(out.causes, kImplausible);
    // 0.5 cm in 1 ms: 500 cm/s raw, (1 - exp(-2 pi 50 Hz 1 ms)) * 500 = 135 cm/s filtered.
    t += kMs;
    out = Update(c, Fresh(t, 0.0, sign * 0.5), t);
    EXPECT_EQ(out.causes, kImplausible);
  }
}

// Model force of the demo model driven by a 2 Hz, 1 cm sine at 1 V, with the velocity
// measured or differentiated from the displacement; the Spencer force as the measurement.
struct SineRun {
  std::vector<double> model, measured;
};
SineRun RunSine(VelocitySource source) {
  ControllerConfig config;
  config.velocity_source = source;
  config.cutoff_hz = 100.0;
  config.law.mode = ControlMode::kConstantVoltage;
  config.law.constant_voltage = 1.0;
  Controller c;
  EXPECT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOk);
  SpencerDamper plant(SpencerParams::Paper(), 20);
  const double w = 2.0 * std::numbers::pi * 2.0;
  plant.Reset(0.0, 1.0);
  SineRun r;
  for (int k = 1; k <= 2000; ++k) {
    const double t0 = (k - 1) * kDt, t1 = k * kDt;
    const double f = plant.Step(kDt, std::sin(w * t0), w * std::cos(w * t0), std::sin(w * t1),
                                w * std::cos(w * t1), 1.0);
    const std::int64_t now = k * kMs;
    const ControllerOutput out = Update(c, Fresh(now, w * std::cos(w * t1), std::sin(w * t1)), now);
    EXPECT_FALSE(out.safe) << k;
    if (k > 500) {  // after the start-up transient
      r.model.push_back(out.model_force);
      r.measured.push_back(f);
    }
  }
  return r;
}

double Rms(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s / static_cast<double>(a.size()));
}

TEST(ControllerFaultTest, DisplacementDerivedVelocityGivesTheMeasuredVelocityModelError) {
  const SineRun measured = RunSine(VelocitySource::kMeasured);
  const SineRun derived = RunSine(VelocitySource::kDisplacement);
  const std::vector<double> zero(measured.model.size(), 0.0);
  const double force_rms = Rms(measured.measured, zero);
  const double error_measured = Rms(measured.model, measured.measured);
  const double error_derived = Rms(derived.model, derived.measured);
  const double between = Rms(derived.model, measured.model);
  RecordProperty("force_rms", std::to_string(force_rms));
  RecordProperty("error_measured", std::to_string(error_measured));
  RecordProperty("error_derived", std::to_string(error_derived));
  RecordProperty("between", std::to_string(between));
  EXPECT_GT(force_rms, 100.0);
  EXPECT_LT(between, 0.1 * force_rms);
  EXPECT_LT(error_derived, 1.1 * error_measured + 0.02 * force_rms);
}

}  // namespace
}  // namespace mrd::firmware
