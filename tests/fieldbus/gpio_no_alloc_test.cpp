// The loop's periods on the GPIO device allocate nothing: encoder edges both ways (velocity
// from the differentiated displacement), an illegal transition, the fault line asserted and
// cleared, enable and heartbeat writes, and a burst of edges beyond one period's bound; enable
// is low whenever the loop is safe and the heartbeat toggles every period. This executable
// replaces the allocator (alloc_counter.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "gpio_test_peer.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/io/gpio/gpio_device.hpp"
#include "mrd/firmware/loop.hpp"
#include "support/alloc_counter.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;

TEST(GpioNoAllocation, GuardSeesAnAllocation) {
  test::AllocationGuard guard;
  std::string s(100, 'x');
  asm volatile("" : : "g"(s.data()) : "memory");
  EXPECT_GE(guard.count(), 1U);
}

TEST(GpioNoAllocation, LoopPeriodsOnTheGpioDeviceAllocateNothing) {
  test::GpioPeer peer("noalloc");
  ASSERT_TRUE(peer.ok()) << peer.error();
  GpioConfig config;
  config.enabled = true;
  config.inputs = Bit(Input::kDisplacement) | Bit(Input::kFaultLine);
  config.outputs = Bit(Output::kEnable) | Bit(Output::kHeartbeat);
  config.sim_chip = peer.path();
  config.encoder_a_line = peer.lines.a;
  config.encoder_b_line = peer.lines.b;
  config.fault_line = peer.lines.fault;
  config.enable_line = peer.lines.enable;
  config.heartbeat_line = peer.lines.heartbeat;
  GpioDevice device(config);
  std::string error;
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&device));
  // A voltage law on the velocity differentiated from the encoder: no other input needed.
  ControllerConfig cc;
  cc.law.mode = ControlMode::kConstantVoltage;
  cc.law.constant_voltage = 1.0;
  cc.velocity_source = VelocitySource::kDisplacement;
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), cc), Error::kOk);
  Telemetry telemetry;
  MonotonicClock clock;
  Loop loop(clock, io, io, controller, telemetry, kPeriod);

  constexpr int kPeriods = 1500;
  int enabled_while_safe = 0, enabled_periods = 0, enabled_in_fault = 0, stuck_heartbeats = 0;
  int enabled_after_fault = 0;
  bool heartbeat = peer.heartbeat();
  test::AllocationGuard guard;
  std::int64_t deadline = clock.Now();
  for (int k = 0; k < kPeriods; ++k) {
    const double t = k * 1e-3;
    // 1 cm amplitude at 2 Hz, 400 counts/cm: up to ~5 edges per period. Stamped in the past
    // by more than the horizon, so each period applies what was written before it.
    peer.MoveTo(static_cast<std::int64_t>(std::lround(400.0 * std::sin(12.566 * t))), 300'000);
    if (k == 400) peer.Glitch(300'000);
    if (k == 1200) peer.MoveTo(peer.count() + 200, 300'000);  // a burst: two periods
    const bool fault = k >= 600 && k < 800;
    peer.SetFault(fault);
    deadline += kPeriod;
    clock.SleepUntil(deadline);
    loop.Tick(clock.Now());
    if (peer.enable()) {
      ++enabled_periods;
      if (loop.stats().safe) ++enabled_while_safe;
      if (k >= 610 && k < 800) ++enabled_in_fault;
      if (k >= 900) ++enabled_after_fault;
    }
    if (peer.heartbeat() == heartbeat) ++stuck_heartbeats;
    heartbeat = peer.heartbeat();
  }
  loop.Shutdown();
  const std::uint64_t allocations = guard.count();
  EXPECT_EQ(allocations, 0U);

  // The paths really ran.
  const DeviceCounters c = device.counters();
  EXPECT_GT(c.rx_ok, 3000U);     // ~6 cm of travel per period of the sine, 400 counts/cm
  EXPECT_EQ(c.rx_rejected, 1U);  // the glitch
  EXPECT_GT(c.tx_ok, 2U * kPeriods - 10);
  EXPECT_EQ(c.tx_failed, 0U);
  EXPECT_EQ(enabled_while_safe, 0);
  EXPECT_GT(enabled_periods, 500);
  EXPECT_EQ(enabled_in_fault, 0);
  EXPECT_GT(enabled_after_fault, 300);
  EXPECT_EQ(stuck_heartbeats, 0);
  EXPECT_GE(loop.stats().watchdog.trips[static_cast<std::size_t>(FaultCause::kFaultLine)], 1U);
  EXPECT_FALSE(peer.enable());  // Shutdown: safe state
  device.Deactivate();
}

}  // namespace
}  // namespace mrd::firmware
