// Controller + Loop against the simulated damper in lockstep, with injected faults.
#include "mrd/firmware/loop.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include "fakes.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;

struct Rig {
  explicit Rig(const ControllerConfig& config = {}) {
    EXPECT_EQ(controller.Configure(test::DemoDamperTable(), config), Error::kOk);
  }
  LockstepClock clock;
  SimulatedDamper plant{SpencerParams::Paper(), SimulationConfig{}, clock, kPeriod};
  test::FaultySource source{plant};
  test::FaultyDriver driver{plant};
  Controller controller;
  Telemetry telemetry;
  Loop loop{clock, source, driver, controller, telemetry, kPeriod};
  std::atomic<bool> stop{false};

  void Run(double seconds) { loop.Run(stop, static_cast<std::int64_t>(seconds * 1e9)); }
};

std::size_t Idx(FaultCause c) { return static_cast<std::size_t>(c); }

TEST(LoopTest, LockstepRunCountsPeriodsAndEndsSafe) {
  Rig rig;
  rig.Run(2.0);
  const TelemetrySnapshot s = rig.telemetry.Read();
  EXPECT_EQ(s.ticks, 2000U);
  EXPECT_EQ(s.overruns, 0U);
  EXPECT_EQ(s.worst_latency_ns, 0);
  EXPECT_TRUE(rig.plant.in_safe_state());
  EXPECT_EQ(rig.plant.held_volts(), 0.0);
  EXPECT_EQ(s.watchdog.entries, 0U);
  EXPECT_GT(s.force_samples, 1900U);
  // Force tracking: every period with a measured force tracks, and the RMS figures are those
  // of a working loop (demand up to 1200 N; model and tracking errors well below it).
  EXPECT_EQ(s.tracking_samples, s.force_samples);
  const double model_rms = std::sqrt(s.sum_sq_model_error / static_cast<double>(s.force_samples));
  const double tracking_rms =
      std::sqrt(s.sum_sq_tracking_error / static_cast<double>(s.tracking_samples));
  EXPECT_LT(model_rms, 300.0);     // measured 224 N
  EXPECT_LT(tracking_rms, 300.0);  // measured 204 N
}

TEST(LoopTest, ForceTrackingCommandsStayInRange) {
  Rig rig;
  double lo = 10.0, hi = -10.0;
  for (int k = 1; k <= 3000; ++k) {
    rig.clock.Advance(kPeriod);
    rig.loop.Tick(rig.clock.Now());
    ASSERT_GE(rig.plant.held_volts(), 0.0);
    ASSERT_LE(rig.plant.held_volts(), 2.25);
    lo = std::min(lo, rig.plant.held_volts());
    hi = std::max(hi, rig.plant.held_volts());
  }
  EXPECT_EQ(rig.loop.stats().ticks, 3000U);
  EXPECT_EQ(rig.driver.safe_calls, 0U);  // every period commanded, none in the safe state
  // The demand swings between 0.3 and 1 of 1200 N: the command uses the whole range.
  EXPECT_LT(lo, 0.1);
  EXPECT_GT(hi, 2.0);
}

TEST(LoopTest, NonFiniteVelocityCommandsSafeStateWithinOnePeriodAndRecovers) {
  ControllerConfig config;
  config.safe_voltage = 0.5;
  Rig rig(config);
  rig.source.nan_velocity = {500, 510};
  for (std::uint64_t k = 0; k < 600; ++k) {
    rig.clock.Advance(kPeriod);
    rig.loop.Tick(rig.clock.Now());
    const bool faulty = k >= 500 && k < 510;
    ASSERT_EQ(rig.plant.in_safe_state(), faulty) << "period " << k;
    if (faulty) {
      ASSERT_EQ(rig.plant.held_volts(), 0.5);
    }
    ASSERT_TRUE(std::isfinite(rig.loop.stats().model_force_n));
  }
  const auto& w = rig.loop.stats().watchdog;
  EXPECT_EQ(w.trips[Idx(FaultCause::kNonFinite)], 1U);
  EXPECT_EQ(w.active_periods[Idx(FaultCause::kNonFinite)], 10U);
}

TEST(LoopTest, ImplausibleVelocityCommandsSafeStateAndKeepsItFromTheModel) {
  ControllerConfig config;
  config.velocity_limit = 100.0;  // the plant moves at <= ~13 cm/s
  Rig rig(config);
  rig.source.spike = {700, 705};
  for (std::uint64_t k = 0; k < 800; ++k) {
    rig.clock.Advance(kPeriod);
    rig.loop.Tick(rig.clock.Now());
    const bool faulty = k >= 700 && k < 705;
    ASSERT_EQ(rig.plant.in_safe_state(), faulty) << "period " << k;
    // The model never saw 500 cm/s: its force stays in the damper's range.
    ASSERT_LT(std::fabs(rig.loop.stats().model_force_n), 3000.0) << "period " << k;
  }
  const auto& w = rig.loop.stats().watchdog;
  EXPECT_EQ(w.trips[Idx(FaultCause::kImplausible)], 1U);
  EXPECT_EQ(w.active_periods[Idx(FaultCause::kImplausible)], 5U);
  EXPECT_STREQ(FaultCauseName(FaultCause::kImplausible), "implausible");
}

TEST(LoopTest, ImplausibleDisplacementTripsOnlyWithALimit) {
  ControllerConfig config;
  config.velocity_source = VelocitySource::kDisplacement;
  config.velocity_limit = 100.0;
  config.displacement_limit = 10.0;
  {
    Rig rig(config);
    rig.source.spike = {700, 703};
    rig.Run(1.0);
    const auto& w = rig.loop.stats().watchdog;
    EXPECT_EQ(w.trips[Idx(FaultCause::kImplausible)], 1U);
    EXPECT_EQ(w.active_periods[Idx(FaultCause::kImplausible)], 3U);
  }
  config.velocity_limit = 0.0;  // no limits: the spike reaches the model (as before)
  config.displacement_limit = 0.0;
  Rig rig(config);
  rig.source.spike = {700, 703};
  rig.Run(1.0);
  EXPECT_EQ(rig.loop.stats().watchdog.trips[Idx(FaultCause::kImplausible)], 0U);
}

TEST(LoopTest, StaleSensorTripsAfterMaxAge) {
  ControllerConfig config;
  config.watchdog.max_age_ns = 3 * kPeriod;
  Rig rig(config);
  rig.source.stall = {100, 120};  // stamps frozen at read 99
  int safe_periods = 0;
  for (std::uint64_t k = 0; k < 200; ++k) {
    rig.clock.Advance(kPeriod);
    rig.loop.Tick(rig.clock.Now());
    if (rig.plant.in_safe_state()) {
      ++safe_periods;
      EXPECT_GE(k, 103U);  // age 4 periods > 3
      EXPECT_LT(k, 120U);
    }
  }
  EXPECT_EQ(safe_periods, 17);
  EXPECT_EQ(rig.loop.stats().watchdog.trips[Idx(FaultCause::kStaleSensor)], 1U);
}

TEST(LoopTest, BusFaultAndFaultLineAreCountedPerCause) {
  Rig rig;
  rig.source.bus_fault = {10, 15};
  rig.source.fault_line = {30, 32};
  for (int k = 0; k < 50; ++k) {
    rig.clock.Advance(kPeriod);
    rig.loop.Tick(rig.clock.Now());
  }
  const auto& s = rig.loop.stats();
  EXPECT_EQ(s.read_faults, 5U);
  EXPECT_EQ(s.watchdog.active_periods[Idx(FaultCause::kBusFault)], 5U);
  EXPECT_EQ(s.watchdog.active_periods[Idx(FaultCause::kFaultLine)], 2U);
  EXPECT_EQ(s.watchdog.entries, 2U);
  EXPECT_FALSE(s.safe);
}

TEST(LoopTest, DriverFaultFallsBackToSafeStateAtOnce) {
  Rig rig;
  rig.driver.fail_from = 20;
  rig.driver.fail_to = 21;
  for (int k = 0; k < 40; ++k) {
    rig.clock.Advance(kPeriod);
    rig.loop.Tick(rig.clock.Now());
    if (k == 20) {
      EXPECT_TRUE(rig.plant.in_safe_state());  // same period
    }
  }
  const auto& s = rig.loop.stats();
  EXPECT_EQ(s.write_faults, 1U);
  EXPECT_EQ(s.watchdog.trips[Idx(FaultCause::kDriverFault)], 1U);
  EXPECT_FALSE(s.safe);
}

TEST(LoopTest, ConstantVoltageAndSkyhookLawsRun) {
  for (const ControlMode mode : {ControlMode::kConstantVoltage, ControlMode::kSkyhookOnOff,
                                 ControlMode::kSkyhookContinuous}) {
    ControllerConfig config;
    config.law.mode = mode;
    config.law.constant_voltage = 1.0;
    Rig rig(config);
    double lo = 10.0, hi = -10.0;
    for (int k = 0; k < 2000; ++k) {
      rig.clock.Advance(kPeriod);
      rig.loop.Tick(rig.clock.Now());
      lo = std::min(lo, rig.plant.held_volts());
      hi = std::max(hi, rig.plant.held_volts());
    }
    if (mode == ControlMode::kConstantVoltage) {
      EXPECT_EQ(lo, 1.0);
      EXPECT_EQ(hi, 1.0);
    } else {
      EXPECT_EQ(lo, 0.0) << ControlModeName(mode);
      EXPECT_GT(hi, 1.0) << ControlModeName(mode);
    }
  }
}

TEST(LoopTest, DisplacementDifferentiatorFeedsTheModelAsWellAsTheMeasuredVelocity) {
  ControllerConfig config;
  config.velocity_source = VelocitySource::kDisplacement;
  config.cutoff_hz = 100.0;
  Rig rig(config);
  rig.Run(1.0);
  EXPECT_EQ(rig.telemetry.Read().watchdog.entries, 0U);
  EXPECT_GT(rig.telemetry.Read().force_samples, 900U);
  Rig measured;
  measured.Run(1.0);
  const auto rms = [](const TelemetrySnapshot& s) {
    return std::sqrt(s.sum_sq_model_error / static_cast<double>(s.force_samples));
  };
  // The derived velocity reaches the model: its model error is that of the measured velocity
  // (240 N both); a model left at v = 0 is far off.
  EXPECT_LT(rms(rig.telemetry.Read()), 1.1 * rms(measured.telemetry.Read()));
}

TEST(ControllerTest, RefusesSafeVoltageOrEmaxOutsideTable) {
  Controller c;
  ControllerConfig config;
  config.safe_voltage = 3.0;
  EXPECT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOutOfRange);
  config = {};
  config.e_max = 5.0;
  EXPECT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOutOfRange);
  config = {};
  config.velocity_limit = -1.0;
  EXPECT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOutOfRange);
  config = {};
  config.displacement_limit = std::nan("");
  EXPECT_EQ(c.Configure(test::DemoDamperTable(), config), Error::kOutOfRange);
}

TEST(TelemetryTest, ReaderSeesConsistentSnapshotsWhileWriterRuns) {
  Telemetry t;
  std::atomic<bool> done{false}, reading{false};
  std::thread writer([&] {
    while (!reading) std::this_thread::yield();  // overlap with the reader even under load
    TelemetrySnapshot s;
    for (std::uint64_t i = 1; i <= 200000; ++i) {
      s.ticks = i;
      s.overruns = i;
      s.last_command_v = static_cast<double>(i);
      t.Write(s);
    }
    done = true;
  });
  std::uint64_t reads = 0, last = 0;
  reading = true;
  while (!done || reads == 0) {
    const TelemetrySnapshot s = t.Read();
    ASSERT_EQ(s.ticks, s.overruns);
    ASSERT_EQ(static_cast<double>(s.ticks), s.last_command_v);
    ASSERT_GE(s.ticks, last);
    last = s.ticks;
    ++reads;
  }
  writer.join();
  EXPECT_EQ(t.Read().ticks, 200000U);
  EXPECT_EQ(t.version(), 200000U);  // one complete write per snapshot
}

}  // namespace
}  // namespace mrd::firmware
