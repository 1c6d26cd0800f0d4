// The firmware's CAN device against a peer on the other end of a SOCK_SEQPACKET socketpair
// (the same fd code as the local frame bus and SocketCAN): accepted samples, every kind of
// bad input rejected and counted, commands within range with the sensor echo, heartbeat and
// status rates, a peer that disappears, and reconnection through a relay.
#include "mrd/firmware/io/can/can_device.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "can_device_peer.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "mrd/protocol/can_codec.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

namespace pc = protocol::can;

class CanDeviceTest : public CanDevicePeerTest {};

TEST_F(CanDeviceTest, AcceptedSensorFramesFillTheRoutedSignalsWithReceiveStamps) {
  SensorFrame frame;
  EXPECT_EQ(Read(&frame), IoStatus::kNoData);
  const std::int64_t before = common::MonotonicNs();
  SendMotion(12.5, -0.75, 100, 0);
  can_frame f{};
  ASSERT_EQ(pc::Encode(pc::SensorForce{-800.0, 3.25, 640.5, 0}, &f), pc::Reject::kNone);
  PeerSend(f);
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  EXPECT_DOUBLE_EQ(frame[Input::kVelocity].value, 12.5);
  EXPECT_DOUBLE_EQ(frame[Input::kDisplacement].value, -0.75);
  EXPECT_DOUBLE_EQ(frame[Input::kDemand].value, -800.0);
  EXPECT_DOUBLE_EQ(frame[Input::kBodyVelocity].value, 3.25);
  EXPECT_DOUBLE_EQ(frame[Input::kForce].value, 640.5);
  EXPECT_GE(frame[Input::kVelocity].stamp_ns, before);
  EXPECT_LE(frame[Input::kVelocity].stamp_ns, common::MonotonicNs());
  EXPECT_EQ(device_->counters().rx_ok, 2U);
  EXPECT_EQ(device_->counters().rx_rejected, 0U);
  // Nothing new: kNoData, the values and their (now ageing) stamps stay.
  const std::int64_t stamp = frame[Input::kVelocity].stamp_ns;
  EXPECT_EQ(Read(&frame), IoStatus::kNoData);
  EXPECT_EQ(frame[Input::kVelocity].stamp_ns, stamp);
}

// The chassis signals (mrd-native SensorChassis, 0x103) reach the frame when routed.
TEST_F(CanDeviceTest, SensorChassisFillsBodyAccelerationAndWheelVelocity) {
  CanConfig c = AllRouted();
  c.inputs |= Bit(Input::kBodyAcceleration) | Bit(Input::kWheelVelocity);
  Make(c);
  const profile::CanProfile& p = profile::NativeCanProfile();
  const profile::SignalRef acc =
      p.inputs[static_cast<std::size_t>(profile::CanIn::kBodyAcceleration)];
  const profile::SignalRef wheel =
      p.inputs[static_cast<std::size_t>(profile::CanIn::kWheelVelocity)];
  ASSERT_TRUE(acc.mapped());
  ASSERT_EQ(acc.message, wheel.message);
  profile::FrameCodec codec(p);
  can_frame f{};
  codec.Begin(acc.message, &f);
  ASSERT_EQ(codec.Set(&f, acc, -123.4), protocol::SignalError::kNone);
  ASSERT_EQ(codec.Set(&f, wheel, 56.78), protocol::SignalError::kNone);
  codec.Seal(acc.message, &f);
  EXPECT_EQ(f.can_id, 0x103U);
  PeerSend(f);
  SensorFrame frame;
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  EXPECT_NEAR(frame[Input::kBodyAcceleration].value, -123.4, 0.05);
  EXPECT_NEAR(frame[Input::kWheelVelocity].value, 56.78, 0.005);
  EXPECT_NE(frame[Input::kBodyAcceleration].stamp_ns, std::numeric_limits<std::int64_t>::min());
  // Not routed: left alone.
  Make(AllRouted());
  codec.Seal(acc.message, &f);  // the next counter
  PeerSend(f);
  SensorFrame other;
  (void)Read(&other);
  EXPECT_EQ(other[Input::kWheelVelocity].stamp_ns, std::numeric_limits<std::int64_t>::min());
}

// The floor accelerations (mrd-native SensorStructure, 0x104) reach the frame when routed.
TEST_F(CanDeviceTest, SensorStructureFillsTheFloorAccelerations) {
  CanConfig c = AllRouted();
  c.inputs |= Bit(Input::kFloorAcceleration1) | Bit(Input::kFloorAcceleration2) |
              Bit(Input::kFloorAcceleration3);
  Make(c);
  const profile::CanProfile& p = profile::NativeCanProfile();
  const profile::CanIn roles[3] = {profile::CanIn::kFloorAcceleration1,
                                   profile::CanIn::kFloorAcceleration2,
                                   profile::CanIn::kFloorAcceleration3};
  const double values[3] = {-1.234, 5.678, 29.5};  // [m/s^2], 0.001 resolution
  profile::FrameCodec codec(p);
  can_frame f{};
  const int m = p.inputs[static_cast<std::size_t>(roles[0])].message;
  ASSERT_GE(m, 0);
  codec.Begin(m, &f);
  for (int i = 0; i < 3; ++i) {
    const profile::SignalRef r = p.inputs[static_cast<std::size_t>(roles[i])];
    ASSERT_EQ(r.message, m);
    ASSERT_EQ(codec.Set(&f, r, values[i]), protocol::SignalError::kNone);
  }
  codec.Seal(m, &f);
  EXPECT_EQ(f.can_id, 0x104U);
  PeerSend(f);
  SensorFrame frame;
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(frame[FloorAcceleration(i)].value, values[i], 0.0005) << i;
    EXPECT_NE(frame[FloorAcceleration(i)].stamp_ns, std::numeric_limits<std::int64_t>::min());
  }
  // Beyond the DBC's range (+-30 m/s^2): not encodable.
  can_frame g{};
  codec.Begin(m, &g);
  EXPECT_NE(codec.Set(&g, p.inputs[static_cast<std::size_t>(roles[2])], 31.0),
            protocol::SignalError::kNone);
}

TEST_F(CanDeviceTest, OnlyRoutedInputsAreMerged) {
  CanConfig c = AllRouted();
  c.inputs = Bit(Input::kVelocity);
  Make(c);
  SendMotion(5.0, 1.0, 1, 0);
  SensorFrame frame;
  frame[Input::kDisplacement] = {42.0, 7};
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  EXPECT_DOUBLE_EQ(frame[Input::kVelocity].value, 5.0);
  EXPECT_DOUBLE_EQ(frame[Input::kDisplacement].value, 42.0);  // served by another bus: untouched
  EXPECT_EQ(frame[Input::kDisplacement].stamp_ns, 7);
}

// Each kind of bad frame is rejected, counted under its reason, and changes nothing.
TEST_F(CanDeviceTest, BadFramesAreRejectedCountedAndChangeNothing) {
  SendMotion(1.0, 0.1, 1, 3);
  SensorFrame frame;
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  const SensorFrame good = frame;

  can_frame f{};
  ASSERT_EQ(pc::Encode(pc::SensorMotion{9.0, 0.9, 2, 4}, &f), pc::Reject::kNone);
  can_frame wrong_dlc = f;
  wrong_dlc.len = 6;
  PeerSend(wrong_dlc);
  can_frame unknown = f;
  unknown.can_id = 0x123;
  PeerSend(unknown);
  can_frame bad_crc = f;
  bad_crc.data[1] ^= 0x20;
  PeerSend(bad_crc);
  can_frame out_of_range = f;
  out_of_range.data[0] = 0x31;  // 30001 counts: 300.01 cm/s
  out_of_range.data[1] = 0x75;
  out_of_range.data[7] = pc::Checksum(out_of_range);
  PeerSend(out_of_range);
  SendMotion(9.0, 0.9, 2, 3);  // repeated counter
  const char runt[3] = {1, 2, 3};
  ASSERT_EQ(write(peer_, runt, sizeof runt), 3);  // not a can_frame at all

  IoError why = IoError::kNone;
  EXPECT_EQ(Read(&frame, &why), IoStatus::kNoData);  // rejects alone are not a bus fault
  EXPECT_DOUBLE_EQ(frame[Input::kVelocity].value, good[Input::kVelocity].value);
  EXPECT_EQ(frame[Input::kVelocity].stamp_ns, good[Input::kVelocity].stamp_ns);
  const DeviceCounters c = device_->counters();
  EXPECT_EQ(c.rx_ok, 1U);
  EXPECT_EQ(c.rx_rejected, 6U);
  EXPECT_EQ(Errors(IoError::kRejectedFrame), 4U);  // wrong DLC, unknown ID, repeated, runt
  EXPECT_EQ(Errors(IoError::kCrc), 1U);
  EXPECT_EQ(Errors(IoError::kBadValue), 1U);

  // Stale counter (behind the last accepted 3): rejected; the sender's next one is accepted.
  SendMotion(9.0, 0.9, 3, 12);
  EXPECT_EQ(Read(&frame), IoStatus::kNoData);
  EXPECT_EQ(device_->counters().rx_rejected, 7U);
  SendMotion(9.0, 0.9, 4, 13);
  EXPECT_EQ(Read(&frame), IoStatus::kOk);
  EXPECT_DOUBLE_EQ(frame[Input::kVelocity].value, 9.0);
}

TEST_F(CanDeviceTest, MoreFramesThanAPeriodsBudgetAreAFlood) {
  // Fill the socket (as a flood of well-formed frames would): more than the budget waits. The
  // frames come as local-bus packets that all entered the bus at one instant, so the flood's
  // arrival span does not depend on how fast this test runs on a loaded machine.
  const std::int64_t entered = common::MonotonicNs();
  int sent = 0;
  for (; sent < 4 * CanDevice::kMaxFramesPerRead; ++sent) {
    canbus::LocalBusPacket packet{};
    ASSERT_EQ(pc::Encode(pc::SensorMotion{1.0, 0.0, static_cast<std::uint16_t>(sent),
                                          static_cast<std::uint8_t>(sent & 15)},
                         &packet.frame),
              pc::Reject::kNone);
    packet.stamp_ns = entered;
    if (send(peer_, &packet, sizeof packet, MSG_DONTWAIT) != static_cast<ssize_t>(sizeof packet)) {
      break;
    }
  }
  ASSERT_GT(sent, CanDevice::kMaxFramesPerRead) << "the socket holds fewer frames than a budget";
  // Each period drains one budget and is a fault while more waits; the rest, once it fits a
  // period, is drained without one.
  SensorFrame frame;
  IoError why = IoError::kNone;
  const int full = (sent - 1) / CanDevice::kMaxFramesPerRead;  // periods ending on a full budget
  for (int i = 1; i <= full; ++i) {
    EXPECT_EQ(Read(&frame, &why), IoStatus::kFault);
    EXPECT_EQ(why, IoError::kOverflow);
    EXPECT_EQ(device_->counters().rx_ok,
              static_cast<std::uint64_t>(i) * CanDevice::kMaxFramesPerRead);
  }
  EXPECT_EQ(Read(&frame, &why), IoStatus::kOk);
  EXPECT_EQ(device_->counters().rx_ok, static_cast<std::uint64_t>(sent));
  EXPECT_EQ(Errors(IoError::kOverflow), static_cast<std::uint64_t>(full));
}

TEST_F(CanDeviceTest, ABacklogSpreadOverAStallIsNoFlood) {
  // Three frames a millisecond for 60 ms while the firmware did not read: more than a budget,
  // but at a healthy bus's rate. Drained over two periods, no fault (the samples are old: the
  // watchdog's stale cause, not the bus's).
  int sent = 0;
  for (int ms = 0; ms < 60; ++ms) {
    for (int i = 0; i < 3; ++i, ++sent) {
      SendMotion(1.0, 0.0, static_cast<std::uint16_t>(sent), static_cast<std::uint8_t>(sent & 15));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_GT(sent, CanDevice::kMaxFramesPerRead);
  SensorFrame frame;
  IoError why = IoError::kNone;
  EXPECT_EQ(Read(&frame, &why), IoStatus::kOk);
  EXPECT_EQ(device_->counters().rx_ok, static_cast<std::uint64_t>(CanDevice::kMaxFramesPerRead));
  EXPECT_EQ(Read(&frame, &why), IoStatus::kOk);
  EXPECT_EQ(device_->counters().rx_ok, static_cast<std::uint64_t>(sent));
  EXPECT_EQ(Errors(IoError::kOverflow), 0U);
}

TEST_F(CanDeviceTest, CommandCarriesSetPointEnableAndTheLatestSensorSeq) {
  SendMotion(1.0, 0.0, 4242, 0);
  SensorFrame frame;
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  IoError why = IoError::kNone;
  ASSERT_EQ(device_->Write(::mrd::test::NowIo(), {1.75, true, false, 0}, &why), IoStatus::kOk);
  ASSERT_EQ(device_->Write(::mrd::test::NowIo(), {0.0, false, true, 1}, &why), IoStatus::kOk);
  std::vector<pc::DriverCommand> commands;
  int heartbeats = 0;
  for (const can_frame& f : PeerDrain()) {
    pc::DriverCommand m;
    pc::Heartbeat hb;
    if (pc::Decode(f, &m) == pc::Reject::kNone) commands.push_back(m);
    if (pc::Decode(f, &hb) == pc::Reject::kNone) ++heartbeats;
  }
  ASSERT_EQ(commands.size(), 2U);
  EXPECT_DOUBLE_EQ(commands[0].volts, 1.75);
  EXPECT_TRUE(commands[0].enable);
  EXPECT_TRUE(commands[0].enable_valid);
  EXPECT_FALSE(commands[0].safe);
  EXPECT_EQ(commands[0].echo_seq, 4242);
  EXPECT_DOUBLE_EQ(commands[1].volts, 0.0);
  EXPECT_FALSE(commands[1].enable);
  EXPECT_TRUE(commands[1].safe);
  EXPECT_EQ(commands[1].counter, (commands[0].counter + 1) & 15);
  EXPECT_EQ(heartbeats, 1);  // the first write; the next is a heartbeat period later
  EXPECT_EQ(device_->counters().tx_ok, 3U);
}

TEST_F(CanDeviceTest, ACommandThatCannotBeRepresentedGoesOutAsTheSafeStateAndFails) {
  for (double bad : {std::numeric_limits<double>::quiet_NaN(), 30.0, -1.0}) {
    IoError why = IoError::kNone;
    EXPECT_EQ(device_->Write(::mrd::test::NowIo(), {bad, true, false, 0}, &why), IoStatus::kFault);
    EXPECT_EQ(why, IoError::kBadValue);
  }
  int commands = 0;
  for (const can_frame& f : PeerDrain()) {
    pc::DriverCommand m;
    if (pc::Decode(f, &m) != pc::Reject::kNone) continue;
    ++commands;
    EXPECT_DOUBLE_EQ(m.volts, 0.0);
    EXPECT_FALSE(m.enable);
    EXPECT_TRUE(m.safe);
  }
  EXPECT_EQ(commands, 3);
  EXPECT_EQ(Errors(IoError::kBadValue), 3U);
}

TEST_F(CanDeviceTest, HeartbeatAndStatusGoOutAtTheirOwnPeriods) {
  CanConfig c = AllRouted();
  c.heartbeat_period_ns = 5'000'000;
  c.status_period_ns = 20'000'000;
  Make(c);
  TelemetrySnapshot stats;
  stats.safe = false;
  stats.active_causes = 0x41;
  stats.overruns = 70000;
  // 101 periods of 1 ms over 100 ms, their time handed in (no sleeping, no wall clock): the
  // schedules run from activation, so whatever the delay since then, the heartbeat goes out at
  // once and every 5 ms (21 frames), the status every 20 ms (6).
  const std::int64_t t0 = common::MonotonicNs();
  int writes = 0;
  for (std::int64_t k = 0; k <= 100; ++k) {
    const IoTime io{t0 + k * 1'000'000, t0 + k * 1'000'000};
    IoError why = IoError::kNone;
    device_->Write(io, {1.0, true, false, static_cast<std::uint64_t>(writes)}, &why);
    device_->PublishStatus(io, stats);
    ++writes;
    PeerDrainInto();
  }
  EXPECT_EQ(heartbeats_, 21);
  EXPECT_EQ(statuses_, 6);
  EXPECT_GT(writes, heartbeats_);
  EXPECT_FALSE(last_status_.safe);
  EXPECT_EQ(last_status_.active_causes, 0x41);
  EXPECT_EQ(last_status_.overruns, 65535);  // saturated
}

TEST_F(CanDeviceTest, APeerThatDisappearsIsAFaultOnReadAndWrite) {
  close(peer_);
  peer_ = -1;
  SensorFrame frame;
  IoError why = IoError::kNone;
  EXPECT_EQ(Read(&frame, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kDisconnected);
  EXPECT_EQ(device_->Write(::mrd::test::NowIo(), {0.0, false, true, 0}, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kDisconnected);
  EXPECT_EQ(Read(&frame, &why), IoStatus::kFault);  // stays faulted (cannot reopen an fd)
  EXPECT_EQ(Errors(IoError::kDisconnected), 1U);
}

// Over the local frame bus: the relay goes away (the HIL exits) and comes back; the device
// faults meanwhile, reopens rate-limited from the tick, and takes data again.
TEST(CanDeviceLocalBus, ReconnectsWhenTheBusComesBack) {
  const std::string path = "/tmp/mrd-can-device-test-" + std::to_string(getpid()) + ".sock";
  auto relay = std::make_unique<canbus::LocalBusRelay>();
  std::string error;
  ASSERT_TRUE(relay->Open(path, &error)) << error;
  CanConfig c = AllRouted();
  c.local_bus = path;
  CanDevice device(c);
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  for (int i = 0; i < 20 && relay->nodes() < 1; ++i) relay->Step(5);
  ASSERT_EQ(relay->nodes(), 1U);

  relay.reset();  // the bus disappears
  SensorFrame frame;
  IoError why = IoError::kNone;
  EXPECT_EQ(device.Read(::mrd::test::NowIo(), &frame, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kDisconnected);
  // Nobody serves: still faulted after the reconnect interval, and the tick never waits.
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  const std::int64_t t0 = common::MonotonicNs();
  EXPECT_EQ(device.Read(::mrd::test::NowIo(), &frame, &why), IoStatus::kFault);
  EXPECT_LT(common::MonotonicNs() - t0, 50'000'000);
  EXPECT_EQ(device.counters().reconnects, 0U);

  relay = std::make_unique<canbus::LocalBusRelay>();
  ASSERT_TRUE(relay->Open(path, &error)) << error;
  const int peer = canbus::OpenLocalBusNode(path.c_str(), &error);
  ASSERT_GE(peer, 0) << error;
  bool ok = false;
  for (int i = 0; i < 100 && !ok; ++i) {
    relay->Step(2);
    if (device.counters().reconnects > 0 && relay->nodes() == 2) {
      can_frame f{};
      ASSERT_EQ(pc::Encode(pc::SensorMotion{3.0, 0.3, 9, static_cast<std::uint8_t>(i & 15)}, &f),
                pc::Reject::kNone);
      ASSERT_EQ(write(peer, &f, sizeof f), static_cast<ssize_t>(sizeof f));
      relay->Step(2);
    }
    ok = device.Read(::mrd::test::NowIo(), &frame, &why) == IoStatus::kOk;
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
  }
  EXPECT_TRUE(ok);
  EXPECT_EQ(device.counters().reconnects, 1U);
  EXPECT_DOUBLE_EQ(frame[Input::kVelocity].value, 3.0);
  close(peer);
}

TEST(CanDeviceConfigure, AMissingBusIsAClearStartUpError) {
  CanConfig c = AllRouted();
  c.local_bus = "/tmp/mrd-no-such-bus.sock";
  CanDevice device(c);
  std::string error;
  EXPECT_FALSE(device.Configure(&error));
  EXPECT_NE(error.find("cannot connect to local bus /tmp/mrd-no-such-bus.sock"), std::string::npos)
      << error;
  CanConfig s = AllRouted();
  s.interface = "mrdcan9";
  CanDevice board(s);
  EXPECT_FALSE(board.Configure(&error));
  EXPECT_NE(error.find("mrdcan9"), std::string::npos) << error;
}

}  // namespace
}  // namespace mrd::firmware
