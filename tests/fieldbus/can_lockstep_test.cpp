// Issue 10: mrd-firmware's loop in lockstep on the CAN device (GrantClock + CanDevice as the
// TimeGrantSource), the test playing the harness over a local-bus socket: one tick per grant,
// sensor stamps in granted time, a missed grant is one safe period (counted, bus timeout) and
// the loop re-aligns on the next grant instead of running ahead; no allocation in the loop.
// This executable replaces the allocator (alloc_counter.hpp).
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/fieldbus_io.hpp"
#include "mrd/firmware/grant_clock.hpp"
#include "mrd/firmware/io/can_device.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/protocol/can_codec.hpp"
#include "support/alloc_counter.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

namespace pc = protocol::can;
constexpr std::int64_t kPeriod = 1'000'000;

// The next DriverCommand from the firmware within timeout_ms; false on timeout.
bool NextCommand(int fd, int timeout_ms, pc::DriverCommand* m) {
  while (true) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, timeout_ms) <= 0) return false;
    can_frame f{};
    while (recv(fd, &f, sizeof f, MSG_DONTWAIT) > 0) {
      if (pc::Decode(f, m) == pc::Reject::kNone) return true;
    }
  }
}

TEST(CanLockstep, OneTickPerGrantMissedGrantIsOneSafePeriodNoAllocation) {
  const std::string path = "/tmp/mrd-can-lockstep-" + std::to_string(getpid()) + ".sock";
  unlink(path.c_str());
  const int listener = socket(AF_UNIX, SOCK_SEQPACKET, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(listen(listener, 4), 0);

  CanConfig config;
  config.enabled = true;
  config.inputs = Bit(Input::kVelocity) | Bit(Input::kDemand);
  config.outputs = Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat);
  config.local_bus = path;
  config.lockstep = true;
  CanDevice device(config);
  std::string error;
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  const int peer = accept(listener, nullptr, nullptr);
  ASSERT_GE(peer, 0);
  ASSERT_EQ(device.grant_source(), &device);
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&device));
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk);
  Telemetry telemetry;
  GrantClock clock(device, 30'000'000, 2'000'000'000);
  Loop loop(clock, io, io, controller, telemetry, kPeriod);

  constexpr int kSteps = 600, kDropGrant = 300;
  std::atomic<bool> stop{false};
  std::atomic<bool> go{false};
  std::thread firmware([&] {
    while (!go.load()) std::this_thread::yield();
    loop.Run(stop, kSteps * kPeriod);
  });
  test::AllocationGuard guard;  // after the thread's own start-up allocation
  go.store(true);
  std::uint8_t counter = 0;
  int answered = 0, safe_after_miss = 0, normal_before_miss = 0, normal_at_end = 0;
  for (int k = 0; k < kSteps; ++k) {
    const double t = k * 1e-3;
    can_frame f{};
    pc::Encode(pc::SensorMotion{12.0 * std::cos(12.566 * t), 0.0, static_cast<std::uint16_t>(k + 1),
                                counter},
               &f);
    write(peer, &f, sizeof f);
    pc::Encode(pc::SensorForce{800.0 * std::tanh(6.0 * std::cos(12.566 * t)), 0.0, 0.0, counter}, &f);
    write(peer, &f, sizeof f);
    if (k != kDropGrant) {
      pc::Encode(pc::TimeGrant{static_cast<std::uint64_t>(k + 1) * 1000U, counter}, &f);
      write(peer, &f, sizeof f);
    }
    counter = static_cast<std::uint8_t>((counter + 1) & 15);
    pc::DriverCommand m;
    if (!NextCommand(peer, 2000, &m)) break;
    ++answered;
    if (m.echo_seq != k + 1) break;  // the tick used this step's sensors
    if (k == kDropGrant && m.safe) ++safe_after_miss;
    if (k == kDropGrant - 1 && !m.safe) ++normal_before_miss;
    if (k == kSteps - 1 && !m.safe) ++normal_at_end;
  }
  const std::uint64_t allocations = guard.count();
  stop.store(true);  // (a broken run must not hang the test: missed grants end the wait)
  firmware.join();
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(answered, kSteps);               // in step after the miss: no permanent offset
  EXPECT_EQ(clock.missed_grants(), 1U);
  EXPECT_EQ(clock.grants(), static_cast<std::uint64_t>(kSteps - 1));
  EXPECT_EQ(normal_before_miss, 1);
  EXPECT_EQ(safe_after_miss, 1);             // the missed grant's period is safe
  EXPECT_EQ(normal_at_end, 1);               // and it recovered
  EXPECT_EQ(device.counters().errors[static_cast<std::size_t>(IoError::kTimeout)], 1U);
  EXPECT_EQ(loop.stats().watchdog.trips[static_cast<std::size_t>(FaultCause::kCanBus)], 1U);
  // Granted time, not wall time: the only overrun is the period skipped by the missed grant.
  EXPECT_EQ(loop.stats().overruns, 1U);
  EXPECT_EQ(loop.stats().ticks, static_cast<std::uint64_t>(kSteps));
  device.Deactivate();
  close(peer);
  close(listener);
  unlink(path.c_str());
}

}  // namespace
}  // namespace mrd::firmware
