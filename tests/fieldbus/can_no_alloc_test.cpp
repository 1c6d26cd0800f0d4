// The loop's periods on the CAN device allocate nothing: reads (good frames, rejected frames,
// silence), command/heartbeat/status writes, the peer disappearing and the rate-limited
// reconnection from the tick; every command stays within [0, E_max]. This executable replaces the
// allocator (alloc_counter.hpp).
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/protocol/can_codec.hpp"
#include "support/alloc_counter.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

namespace pc = protocol::can;
constexpr std::int64_t kPeriod = 1'000'000;

TEST(CanNoAllocation, GuardSeesAnAllocation) {
  test::AllocationGuard guard;
  std::string s(100, 'x');
  asm volatile("" : : "g"(s.data()) : "memory");
  EXPECT_GE(guard.count(), 1U);
}

TEST(CanNoAllocation, LoopPeriodsOnTheCanDeviceAllocateNothing) {
  // The test plays the local bus itself: a listening socket the device connects to.
  const std::string path = "/tmp/mrd-can-noalloc-" + std::to_string(getpid()) + ".sock";
  unlink(path.c_str());
  const int listener = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(listen(listener, 4), 0);

  CanConfig config;
  config.enabled = true;
  config.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand) |
                  Bit(Input::kBodyVelocity) | Bit(Input::kForce);
  config.outputs =
      Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat) | Bit(Output::kStatus);
  config.local_bus = path;
  config.status_period_ns = 20'000'000;
  CanDevice device(config);
  std::string error;
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  int peer = accept4(listener, nullptr, nullptr, SOCK_NONBLOCK);
  ASSERT_GE(peer, 0);
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&device));
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk);
  Telemetry telemetry;
  MonotonicClock clock;
  Loop loop(clock, io, io, controller, telemetry, kPeriod);

  constexpr int kPeriods = 1500;
  std::uint8_t counter = 0;
  int commands = 0, out_of_range = 0;
  bool left_safe_after_reconnect = false;
  test::AllocationGuard guard;
  std::int64_t deadline = clock.Now();
  for (int k = 0; k < kPeriods; ++k) {
    const bool silent = k >= 300 && k < 350;  // sensors stop: stale data
    if (k == 700 && peer >= 0) {              // the peer disappears
      close(peer);
      peer = -1;
    }
    if (peer < 0 && k > 700) peer = accept4(listener, nullptr, nullptr, SOCK_NONBLOCK);
    if (peer >= 0 && !silent) {
      const double t = k * 1e-3;
      can_frame f{};
      pc::Encode(pc::SensorMotion{12.0 * std::cos(12.566 * t), std::sin(12.566 * t),
                                  static_cast<std::uint16_t>(k), counter},
                 &f);
      write(peer, &f, sizeof f);
      pc::Encode(pc::SensorForce{800.0 * std::tanh(6.0 * std::cos(12.566 * t)), 0.0, 0.0, counter},
                 &f);
      write(peer, &f, sizeof f);
      counter = static_cast<std::uint8_t>((counter + 1) & 15);
      if (k == 500) {  // rejected frames: bad checksum, wrong DLC, unknown ID
        f.data[0] ^= 1;
        write(peer, &f, sizeof f);
        f.len = 3;
        write(peer, &f, sizeof f);
        f.can_id = 0x555;
        write(peer, &f, sizeof f);
      }
    }
    deadline += kPeriod;
    clock.SleepUntil(deadline);
    loop.Tick(clock.Now());
    if (peer >= 0) {
      can_frame f{};
      while (recv(peer, &f, sizeof f, MSG_DONTWAIT) > 0) {
        pc::DriverCommand m;
        if (pc::Decode(f, &m) == pc::Reject::kNone) {
          ++commands;
          if (!(m.volts >= 0.0 && m.volts <= ControllerConfig{}.e_max)) ++out_of_range;
          if (k > 800 && !m.safe) left_safe_after_reconnect = true;
        }
      }
    }
  }
  loop.Shutdown();
  const std::uint64_t allocations = guard.count();
  EXPECT_EQ(allocations, 0U);

  // The paths really ran.
  const DeviceCounters c = device.counters();
  EXPECT_EQ(c.reconnects, 1U);
  EXPECT_GE(c.rx_rejected, 3U);
  EXPECT_GT(c.rx_ok, 1000U);
  EXPECT_GT(commands, 1000);
  EXPECT_EQ(out_of_range, 0);  // never outside [0, E_max], faults or not
  EXPECT_GE(loop.stats().watchdog.entries, 2U);
  EXPECT_GE(loop.stats().watchdog.trips[static_cast<std::size_t>(FaultCause::kCanBus)], 1U);
  EXPECT_TRUE(left_safe_after_reconnect);
  device.Deactivate();
  if (peer >= 0) close(peer);
  close(listener);
  unlink(path.c_str());
}

}  // namespace
}  // namespace mrd::firmware
