// The loop's periods on a CAN device running a device profile allocate nothing, for the CAN
// profiles the toolkit ships or tests with (CANopen's start-up handshake and the Modbus and
// PWM devices have their own guards: canopen_device_test, modbus_profile_no_alloc_tests,
// pwm_device_test): sensor frames in the profile's messages (sealed with
// its counters and checksums by the test, as the driver and sensors would), rejected frames, a
// silent stretch, the set-point through the profile's command map. This executable replaces
// the allocator (alloc_counter.hpp). Labels profile, fieldbus.
//
// Each period runs at its exact deadline handed in (Loop::Tick(IoTime)), not at the time the
// test wakes up: a loaded machine that wakes the test late cannot merge two periods into one
// millisecond of wall time, so every period runs its schedules (the status every period, the
// heartbeat) and the frame counts are exact. The test still sleeps until each deadline, so
// CLOCK_MONOTONIC is never behind the handed-in time; its frames carry the previous period's
// time as the bus's stamp (LocalBusPacket; a receive stamp is the earlier of the packet's and
// the arrival's), so the device's sample stamps are the handed-in time too.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "support/alloc_counter.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

using profile::CanIn;
using profile::CanOut;
constexpr std::int64_t kPeriod = 1'000'000;
const std::string kSource = MRD_SOURCE_DIR;

// (Plain TESTs calling one function: a parameterized suite in a file that replaces the
// allocator trips GCC's -Wmismatched-new-delete inside GoogleTest.)
void LoopPeriodsAllocateNothing(const char* file) {
  SCOPED_TRACE(file);
  auto p = std::make_shared<profile::CanProfile>();
  std::string error;
  ASSERT_TRUE(profile::LoadCanProfile(kSource + "/" + file, p.get(), &error)) << error;
  const auto in = [&](CanIn r) { return p->inputs[static_cast<std::size_t>(r)]; };
  const auto out = [&](CanOut r) { return p->outputs[static_cast<std::size_t>(r)]; };
  ASSERT_TRUE(in(CanIn::kVelocity).mapped() && in(CanIn::kDemand).mapped());
  // A profile whose set-point leaves on another bus (pwm-enable: a PWM duty) runs its CAN
  // side here: sensors in, heartbeat and status out.
  const bool command_on_can = out(CanOut::kCommand).mapped();

  const std::string path = "/tmp/mrd-profile-noalloc-" + std::to_string(getpid()) + ".sock";
  unlink(path.c_str());
  const int listener = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(listen(listener, 4), 0);

  CanConfig config;
  config.enabled = true;
  config.inputs = Bit(Input::kVelocity) | Bit(Input::kDemand);
  if (in(CanIn::kDisplacement).mapped()) config.inputs |= Bit(Input::kDisplacement);
  config.outputs = command_on_can ? Bit(Output::kCommand) : 0U;
  if (out(CanOut::kStatusSafe).mapped()) config.outputs |= Bit(Output::kStatus);
  if (out(CanOut::kEnable).mapped()) config.outputs |= Bit(Output::kEnable);
  if (out(CanOut::kHeartbeatSafe).mapped()) config.outputs |= Bit(Output::kHeartbeat);
  config.local_bus = path;
  config.status_period_ns = kPeriod;  // as mrd-hil runs it: the status every period
  config.profile = file;
  config.can_profile = p;
  CanDevice device(config);
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  const int peer = accept4(listener, nullptr, nullptr, SOCK_NONBLOCK);
  ASSERT_GE(peer, 0);
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&device));
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk);
  Telemetry telemetry;
  MonotonicClock clock;
  Loop loop(clock, io, io, controller, telemetry, kPeriod);

  // The test's side of the bus: its own codec on the same profile.
  profile::FrameCodec peer_codec(*p);
  const int motion = in(CanIn::kVelocity).message, demand = in(CanIn::kDemand).message;
  const int command = out(CanOut::kCommand).message;
  // Sent at t_ns (the packet's bus stamp; never later than CLOCK_MONOTONIC at the send).
  const auto send = [&](int m, double v, double x, double f, int k, std::int64_t t_ns) {
    can_frame frame{};
    peer_codec.Begin(m, &frame);
    if (m == motion) {
      (void)peer_codec.Set(&frame, in(CanIn::kVelocity), v);
      if (in(CanIn::kDisplacement).mapped() && in(CanIn::kDisplacement).message == m) {
        (void)peer_codec.Set(&frame, in(CanIn::kDisplacement), x);
      }
      if (in(CanIn::kSensorSeq).mapped() && in(CanIn::kSensorSeq).message == m) {
        (void)peer_codec.Set(&frame, in(CanIn::kSensorSeq), k & 255);
      }
    }
    if (m == demand) (void)peer_codec.Set(&frame, in(CanIn::kDemand), f);
    peer_codec.Seal(m, &frame);
    const canbus::LocalBusPacket packet{frame, t_ns};
    (void)write(peer, &packet, sizeof packet);
    return frame;
  };

  constexpr int kPeriods = 1200;
  int commands = 0;
  test::AllocationGuard guard;
  std::int64_t deadline = clock.Now();
  for (int k = 0; k < kPeriods; ++k) {
    const bool silent = k >= 300 && k < 350;  // sensors stop: stale data
    const std::int64_t sent = deadline;       // the previous period's time: passed already
    if (!silent) {
      const double t = k * 1e-3;
      const double v = 12.0 * std::cos(12.566 * t), x = std::sin(12.566 * t);
      const double f = 800.0 * std::tanh(6.0 * std::cos(12.566 * t));
      can_frame last = send(motion, v, x, f, k, sent);
      if (demand != motion) last = send(demand, v, x, f, k, sent);
      if (k == 500) {  // rejected: a repeated frame (counter or checksum), a wrong length
        (void)write(peer, &last, sizeof last);
        last.len = static_cast<__u8>(last.len == 1 ? 2 : 1);
        (void)write(peer, &last, sizeof last);
      }
    }
    deadline += kPeriod;
    clock.SleepUntil(deadline);             // CLOCK_MONOTONIC at least the period's time
    loop.Tick(IoTime{deadline, deadline});  // the exact period time, however late the wake-up
    can_frame f{};
    while (recv(peer, &f, sizeof f, MSG_DONTWAIT) > 0) {
      if (peer_codec.Find(f) >= 0 && (!command_on_can || peer_codec.Find(f) == command)) {
        ++commands;
      }
    }
  }
  loop.Shutdown(IoTime{deadline, deadline});
  EXPECT_EQ(guard.count(), 0U) << file;
  // The paths really ran.
  const DeviceCounters c = device.counters();
  EXPECT_GT(c.rx_ok, 1000U) << file;
  EXPECT_GE(c.rx_rejected, 1U) << file;
  EXPECT_GT(commands, 1000) << file;  // command frames (else: the firmware's other frames)
  device.Deactivate();
  close(peer);
  close(listener);
  unlink(path.c_str());
}

TEST(ProfileNoAllocation, MrdNative) {
  LoopPeriodsAllocateNothing("firmware/profiles/mrd-native.toml");
}
TEST(ProfileNoAllocation, PwmEnableCanSide) {
  LoopPeriodsAllocateNothing("firmware/profiles/pwm-enable.toml");
}
TEST(ProfileNoAllocation, TestDriver) {
  LoopPeriodsAllocateNothing("tests/data/profiles/test-driver.toml");
}

}  // namespace
}  // namespace mrd::firmware
