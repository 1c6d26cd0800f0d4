// mrd-firmware's loop in lockstep on the CAN device (GrantClock + CanDevice as the
// TimeGrantSource), the test playing the harness over a local-bus socket: one tick per grant,
// sensor stamps in granted time, a grant that comes 150 ms late (a stalled harness) is waited
// for and changes nothing (no safe period, no overrun, no bus timeout); a harness that is gone
// ends the loop in the safe state; no allocation in the loop.
// This executable replaces the allocator (alloc_counter.hpp).
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>

#include "mrd/common/clock.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/telemetry.hpp"
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

// A listening local-bus socket the firmware's device connects to (the test is the harness).
struct HarnessSocket {
  HarnessSocket() {
    unlink(path.c_str());
    listener = socket(AF_UNIX, SOCK_SEQPACKET, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
    ok = bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
         listen(listener, 4) == 0;
  }
  ~HarnessSocket() {
    if (peer >= 0) close(peer);
    close(listener);
    unlink(path.c_str());
  }
  CanConfig Config() const {
    CanConfig config;
    config.enabled = true;
    config.inputs = Bit(Input::kVelocity) | Bit(Input::kDemand);
    config.outputs = Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat);
    config.local_bus = path;
    config.lockstep = true;
    return config;
  }
  const std::string path = "/tmp/mrd-can-lockstep-" + std::to_string(getpid()) + ".sock";
  int listener = -1;
  int peer = -1;
  bool ok = false;
};

// The harness socket and the firmware's side of the bus: the lockstep CAN device, the
// composite io over it, the controller and telemetry a Loop needs.
struct LockstepRig {
  // The device configured, active and accepted (bus.peer), in io; the controller on the demo
  // table.
  void Start() {
    ASSERT_TRUE(bus.ok);
    std::string error;
    ASSERT_TRUE(device.Configure(&error)) << error;
    ASSERT_TRUE(device.Activate(&error)) << error;
    bus.peer = accept(bus.listener, nullptr, nullptr);
    ASSERT_GE(bus.peer, 0);
    ASSERT_TRUE(io.Add(&device));
    ASSERT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk);
  }

  HarnessSocket bus;  // outlives the device
  CanDevice device{bus.Config()};
  FieldbusIo io;
  Controller controller;
  Telemetry telemetry;
};

TEST(CanLockstep, OneTickPerGrantALateGrantChangesNothingNoAllocation) {
  LockstepRig rig;
  ASSERT_NO_FATAL_FAILURE(rig.Start());
  const int peer = rig.bus.peer;
  ASSERT_EQ(rig.device.grant_source(), &rig.device);
  GrantClock clock(rig.device, 10'000'000'000);
  Loop loop(clock, rig.io, rig.io, rig.controller, rig.telemetry, kPeriod);

  constexpr int kSteps = 600, kLateGrant = 300;
  std::atomic<bool> stop{false};
  std::atomic<bool> go{false};
  std::thread firmware([&] {
    while (!go.load()) std::this_thread::yield();
    loop.Run(stop, kSteps * kPeriod);
  });
  test::AllocationGuard guard;  // after the thread's own start-up allocation
  go.store(true);
  std::uint8_t counter = 0;
  int answered = 0, safe_commands = 0, normal_late = 0, normal_at_end = 0;
  for (int k = 0; k < kSteps; ++k) {
    const double t = k * 1e-3;
    can_frame f{};
    pc::Encode(pc::SensorMotion{12.0 * std::cos(12.566 * t), 0.0, static_cast<std::uint16_t>(k + 1),
                                counter},
               &f);
    write(peer, &f, sizeof f);
    pc::Encode(pc::SensorForce{800.0 * std::tanh(6.0 * std::cos(12.566 * t)), 0.0, 0.0, counter},
               &f);
    write(peer, &f, sizeof f);
    if (k == kLateGrant) std::this_thread::sleep_for(std::chrono::milliseconds(150));
    pc::Encode(pc::TimeGrant{static_cast<std::uint64_t>(k + 1) * 1000U, counter}, &f);
    write(peer, &f, sizeof f);
    counter = static_cast<std::uint8_t>((counter + 1) & 15);
    pc::DriverCommand m;
    if (!NextCommand(peer, 2000, &m)) break;
    ++answered;
    if (m.echo_seq != k + 1) break;  // the tick used this step's sensors
    if (m.safe) ++safe_commands;
    if (k == kLateGrant && !m.safe) ++normal_late;
    if (k == kSteps - 1 && !m.safe) ++normal_at_end;
  }
  const std::uint64_t allocations = guard.count();
  stop.store(true);  // (a broken run must not hang the test: the stop ends the wait)
  firmware.join();
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(answered, kSteps);
  EXPECT_FALSE(clock.gave_up());
  EXPECT_EQ(clock.grants(), static_cast<std::uint64_t>(kSteps));
  EXPECT_EQ(normal_late, 1);    // the late grant's period is a normal one
  EXPECT_EQ(safe_commands, 0);  // and none was safe
  EXPECT_EQ(normal_at_end, 1);
  EXPECT_EQ(rig.device.counters().errors[static_cast<std::size_t>(IoError::kTimeout)], 0U);
  EXPECT_EQ(loop.stats().watchdog.entries, 0U);
  // Granted time, not wall time: 150 ms of waiting is no overrun.
  EXPECT_EQ(loop.stats().overruns, 0U);
  EXPECT_EQ(loop.stats().ticks, static_cast<std::uint64_t>(kSteps));
  rig.device.Deactivate();
}

// Lockstep: a period's frames (command, heartbeat, status and telemetry) reach the harness
// together, at the end of PublishStatus, so it wakes once for them: nothing is on the socket
// after Write, all of them in order after PublishStatus. A Write outside a period (the loop's
// shut-down, after its last PublishStatus) goes out at once.
TEST(CanLockstep, APeriodsFramesLeaveTogetherAfterItsStatus) {
  HarnessSocket bus;
  ASSERT_TRUE(bus.ok);
  CanConfig config = bus.Config();
  config.outputs |= Bit(Output::kStatus);
  CanDevice device(config);
  std::string error;
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  bus.peer = accept(bus.listener, nullptr, nullptr);
  ASSERT_GE(bus.peer, 0);
  // The ids waiting on the harness's socket, in order, "-" separated (no container: this
  // executable counts allocations).
  const auto take = [&]() {
    std::string ids;
    can_frame f{};
    while (recv(bus.peer, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) {
      char id[8];
      std::snprintf(id, sizeof id, "%s%03X", ids.empty() ? "" : "-", f.can_id);
      ids += id;
    }
    return ids;
  };
  char expected[32];
  const IoTime io{0, common::MonotonicNs()};
  IoError why = IoError::kNone;
  SensorFrame frame;
  (void)device.Read(io, &frame, &why);  // the period begins (no samples yet)
  ASSERT_EQ(device.Write(io, DriverCommand{1.0, true, false, 0}, &why), IoStatus::kOk);
  EXPECT_EQ(take(), "");  // held
  TelemetrySnapshot stats{};
  device.PublishStatus(io, stats);
  // FirmwareStatus, then FirmwareTelemetry (docs/mrd.dbc).
  std::snprintf(expected, sizeof expected, "%03X-%03X-%03X-%03X", pc::kDriverCommandId,
                pc::kHeartbeatId, pc::kFirmwareStatusId, pc::kFirmwareStatusId + 1);
  EXPECT_EQ(take(), expected);
  EXPECT_EQ(device.counters().tx_ok, 4U);
  EXPECT_EQ(device.counters().tx_failed, 0U);
  // The loop's shut-down: a Write after the last period's status, out at once.
  ASSERT_EQ(device.Write(io, DriverCommand{0.0, false, true, 1}, &why), IoStatus::kOk);
  std::snprintf(expected, sizeof expected, "%03X", pc::kDriverCommandId);
  EXPECT_EQ(take(), expected);
  device.Deactivate();
  EXPECT_EQ(take(), expected);
}

// The harness goes away mid-run (no more grants): after the give-up time the clock halts, the
// loop ends and leaves a safe command on the bus; no period was ticked without time.
TEST(CanLockstep, AHarnessThatIsGoneEndsTheLoopInTheSafeState) {
  LockstepRig rig;
  ASSERT_NO_FATAL_FAILURE(rig.Start());
  const int peer = rig.bus.peer;
  GrantClock clock(rig.device, 200'000'000);  // 0.2 s without a grant: gone
  Loop loop(clock, rig.io, rig.io, rig.controller, rig.telemetry, kPeriod);
  std::atomic<bool> stop{false};
  std::thread firmware([&] { loop.Run(stop, 0); });  // no duration: only the halt ends it
  std::uint8_t counter = 0;
  constexpr int kSteps = 50;
  int answered = 0;
  for (int k = 0; k < kSteps; ++k) {
    can_frame f{};
    pc::Encode(pc::SensorMotion{5.0, 0.0, static_cast<std::uint16_t>(k + 1), counter}, &f);
    write(peer, &f, sizeof f);
    pc::Encode(pc::SensorForce{100.0, 0.0, 0.0, counter}, &f);
    write(peer, &f, sizeof f);
    pc::Encode(pc::TimeGrant{static_cast<std::uint64_t>(k + 1) * 1000U, counter}, &f);
    write(peer, &f, sizeof f);
    counter = static_cast<std::uint8_t>((counter + 1) & 15);
    pc::DriverCommand m;
    if (!NextCommand(peer, 2000, &m)) break;
    ++answered;
  }
  ASSERT_EQ(answered, kSteps);
  // Silence: the loop must end by itself (the test's own bound is 20 s, far above 0.2 s).
  for (int i = 0; i < 2000 && !clock.Halted(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const bool halted = clock.Halted();
  if (!halted) stop.store(true);
  firmware.join();
  EXPECT_TRUE(halted);
  EXPECT_TRUE(clock.gave_up());
  EXPECT_EQ(loop.stats().ticks, static_cast<std::uint64_t>(kSteps));  // none without a grant
  EXPECT_TRUE(loop.stats().safe);
  pc::DriverCommand last;
  bool any = false;
  for (pc::DriverCommand m; NextCommand(peer, 200, &m);) {
    last = m;
    any = true;
  }
  ASSERT_TRUE(any);
  EXPECT_TRUE(last.safe);
  EXPECT_EQ(last.volts, 0.0);
  rig.device.Deactivate();
}

}  // namespace
}  // namespace mrd::firmware
