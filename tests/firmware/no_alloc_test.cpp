// Proves the loop step allocates nothing: this executable replaces the global operator
// new/delete (and, outside sanitizer builds, glibc's malloc family) with counting versions
// (tests/support/alloc_counter.hpp); AllocationGuard counts any allocation in its scope. Loop
// steps cover model, inverter, control law, watchdog (entering and leaving the safe state),
// simulated I/O and telemetry publishing.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "fakes.hpp"
#include "mrd/firmware/clipped_optimal.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/platform/clipped_optimal_file.hpp"
#include "mrd/firmware/platform/runtime_params.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"
#include "reference_models.hpp"
// GCC 12 takes the counting operator delete's free() for a mismatch with the counting new
// once a std::string or unique_ptr release (platform::RuntimeParams) is inlined here: a false
// positive.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include "support/alloc_counter.hpp"  // replaces the allocator of this executable
#pragma GCC diagnostic pop
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

using test::AllocationGuard;

constexpr std::int64_t kPeriod = 1'000'000;

// Keeps the optimiser from eliding a new/delete or malloc/free pair.
void Escape(void* p) { asm volatile("" : : "g"(p) : "memory"); }

std::uint64_t AllocationsInSteps(const ControllerConfig& config, int steps,
                                 const CoefficientTable& table = test::DemoDamperTable()) {
  LockstepClock clock;
  SimulatedDamper plant(SpencerParams::Paper(), SimulationConfig{}, clock, kPeriod);
  test::FaultySource source(plant);
  source.nan_velocity = {1000, 1010};
  source.stall = {2000, 2050};
  source.bus_fault = {3000, 3005};
  source.fault_line = {4000, 4002};
  test::FaultyDriver driver(plant);
  driver.fail_from = 4500;
  driver.fail_to = 4501;
  Controller controller;
  EXPECT_EQ(controller.Configure(table, config), Error::kOk);
  Telemetry telemetry;
  Loop loop(clock, source, driver, controller, telemetry, kPeriod);
  AllocationGuard guard;
  for (int k = 0; k < steps; ++k) {
    clock.Advance(kPeriod);
    loop.Tick(clock.Now());
  }
  loop.Shutdown();
  (void)telemetry.Read();
  const std::uint64_t n = guard.count();
  EXPECT_GT(loop.stats().watchdog.entries, 3U);  // the faults really happened
  return n;
}

TEST(NoAllocationTest, GuardCatchesADeliberateAllocation) {
  {
    AllocationGuard guard;
    auto* p = new int(7);
    Escape(p);
    delete p;
    EXPECT_GE(guard.count(), 1U);
  }
  {
    AllocationGuard guard;
    std::vector<double> v(16);
    Escape(v.data());
    EXPECT_GE(guard.count(), 1U);
  }
#if MRD_HOOK_MALLOC
  {
    AllocationGuard guard;
    void* p = std::malloc(32);
    Escape(p);
    std::free(p);
    EXPECT_GE(guard.count(), 1U);
  }
#endif
}

TEST(NoAllocationTest, ForceTrackingLoopStepsAllocateNothing) {
  EXPECT_EQ(AllocationsInSteps({}, 5000), 0U);
}

TEST(NoAllocationTest, LowPassModelStepsAllocateNothing) {
  EXPECT_EQ(AllocationsInSteps({}, 5000, test::LowPassTable()), 0U);
}

// The inversion's semi-active choices (E_min for a zero or non-dissipative demand, the rising
// envelope of a model non-monotone in E, its monotony verdict) on a model that is
// non-monotone where |v| > 6 cm/s, under force tracking and skyhook.
TEST(NoAllocationTest, NonMonotoneModelInversionAllocatesNothing) {
  ControllerConfig config;
  EXPECT_EQ(AllocationsInSteps(config, 5000, test::NonMonotoneTable()), 0U);
  config.law.mode = ControlMode::kSkyhookContinuous;
  EXPECT_EQ(AllocationsInSteps(config, 5000, test::NonMonotoneTable()), 0U);
}

TEST(NoAllocationTest, DisplacementVelocityAndSkyhookStepsAllocateNothing) {
  ControllerConfig config;
  config.velocity_source = VelocitySource::kDisplacement;
  config.law.mode = ControlMode::kSkyhookContinuous;
  EXPECT_EQ(AllocationsInSteps(config, 5000), 0U);
  config.law.mode = ControlMode::kSkyhookOnOff;
  EXPECT_EQ(AllocationsInSteps(config, 5000), 0U);
  config.law.mode = ControlMode::kConstantVoltage;
  EXPECT_EQ(AllocationsInSteps(config, 5000), 0U);
}

// Every law, on the dry-run plant (it serves body and wheel velocity and body acceleration).
TEST(NoAllocationTest, EveryControlLawStepsAllocateNothing) {
  for (const ControlMode mode :
       {ControlMode::kForceTracking, ControlMode::kConstantVoltage, ControlMode::kSkyhookOnOff,
        ControlMode::kSkyhookContinuous, ControlMode::kOpenLoop, ControlMode::kGroundhook,
        ControlMode::kGroundhookOnOff, ControlMode::kHybrid, ControlMode::kAdd,
        ControlMode::kSkyhookAdd}) {
    SCOPED_TRACE(ControlModeName(mode));
    ControllerConfig config;
    config.law.mode = mode;
    EXPECT_EQ(AllocationsInSteps(config, 5000), 0U);
  }
}

TEST(NoAllocationTest, LockstepRunAllocatesNothing) {
  LockstepClock clock;
  SimulatedDamper plant(SpencerParams::Paper(), SimulationConfig{}, clock, kPeriod);
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk);
  Telemetry telemetry;
  Loop loop(clock, plant, plant, controller, telemetry, kPeriod);
  std::atomic<bool> stop{false};
  AllocationGuard guard;
  loop.Run(stop, 3'000'000'000);
  EXPECT_EQ(guard.count(), 0U);
  EXPECT_EQ(loop.stats().ticks, 3000U);
}

// A parameter change and a reload applied through the period hook (platform::RuntimeParams):
// checked and prepared before the guard, applied by the loop inside it.
TEST(NoAllocationTest, ParameterChangeAndReloadAtAPeriodBoundaryAllocateNothing) {
  LockstepClock clock;
  SimulatedDamper plant(SpencerParams::Paper(), SimulationConfig{}, clock, kPeriod);
  platform::FirmwareConfig config;
  config.controller.law.mode = ControlMode::kSkyhookContinuous;
  config.controller.e_max = test::DemoDamperTable().e_max;
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), config.controller), Error::kOk);
  Telemetry telemetry;
  Loop loop(clock, plant, plant, controller, telemetry, kPeriod);
  platform::RuntimeParams params(test::DemoDamperTable(), config);
  loop.SetHook(&params);
  const auto ticks = [&](int n) {
    for (int k = 0; k < n; ++k) {
      clock.Advance(kPeriod);
      loop.Tick(clock.Now());
    }
  };
  ticks(100);
  ASSERT_EQ(params.PostSet("control.skyhook_gain", "40").status,
            platform::RuntimeParams::Status::kOk);
  {
    AllocationGuard guard;
    ticks(100);
    EXPECT_EQ(guard.count(), 0U);
  }
  platform::RuntimeParams::Result r = params.Finish(1000);
  ASSERT_EQ(r.status, platform::RuntimeParams::Status::kOk) << r.message;
  EXPECT_EQ(r.period, 100U);
  EXPECT_EQ(loop.controller().config().law.skyhook_gain, 40.0);
  platform::FirmwareConfig next = params.config();
  next.controller.law.mode = ControlMode::kForceTracking;
  ASSERT_EQ(params.PostReload(next, test::DemoDamperTable(), nullptr).status,
            platform::RuntimeParams::Status::kOk);
  {
    AllocationGuard guard;
    ticks(100);
    EXPECT_EQ(guard.count(), 0U);
  }
  r = params.Finish(1000);
  ASSERT_EQ(r.status, platform::RuntimeParams::Status::kOk) << r.message;
  EXPECT_EQ(r.period, 200U);
  EXPECT_NE(&loop.controller(), &controller);
  EXPECT_EQ(loop.controller().config().law.mode, ControlMode::kForceTracking);
  EXPECT_EQ(params.version(), 2U);
}

// The clipped-optimal law through the loop (Controller: observer, clipped rule or the model's
// inverse at the desired force, watchdog on its inputs), with the designed gains on the
// dry-run plant (it serves the stand-in floor accelerations and the force).
TEST(NoAllocationTest, ClippedOptimalLoopStepsAllocateNothing) {
  ControllerConfig config;
  config.law.mode = ControlMode::kClippedOptimal;
  std::string error;
  ASSERT_TRUE(platform::LoadClippedOptimalGains(
      std::string(MRD_SOURCE_DIR) + "/hil/data/clipped_optimal_gains.toml", &config.clipped_gains,
      &error))
      << error;
  config.clipped_gains_loaded = true;
  for (const ClippedCommand command : {ClippedCommand::kClipped, ClippedCommand::kInverse}) {
    config.law.clipped_command = command;
    EXPECT_EQ(AllocationsInSteps(config, 5000), 0U);
  }
}

// The clipped-optimal law (observer update, optimal force, clipped rule) per period.
TEST(NoAllocationTest, ClippedOptimalUpdatesAllocateNothing) {
  ClippedOptimalGains gains;
  for (int i = 0; i < ClippedOptimalGains::kStates; ++i) {
    gains.ad[i * ClippedOptimalGains::kStates + i] = 0.999;
    gains.bd[i] = 1e-6;
    gains.k[i] = 100.0 * (i + 1);
  }
  for (double& l : gains.l) l = 1e-3;
  for (double& c : gains.cy) c = -10.0;
  ClippedOptimal law;
  law.Configure(gains);
  int high = 0;
  AllocationGuard guard;
  for (int k = 0; k < 5000; ++k) {
    const Real accel[3] = {Real(0.01 * (k % 17)), Real(-0.02 * (k % 5)), Real(0.3)};
    if (law.Update(accel, Real((k % 40) - 20)) > Real(0)) ++high;
  }
  EXPECT_EQ(guard.count(), 0U);
  EXPECT_GT(high, 0);  // the rule really switched
}

}  // namespace
}  // namespace mrd::firmware
