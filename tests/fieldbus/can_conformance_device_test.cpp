// Conformance of the firmware's CAN device (docs/can_bus.md) against a peer on a socketpair:
// samples keep their arrival stamps (a stalled firmware sees their true age), a backlog is
// drained to the newest frame, a babbling node is a flood (bus fault), no driving command
// leaves on a sample older than max_age, and a driver fault in DriverStatus asserts the fault
// line (the watchdog cause the Modbus driver-fault bit raises).
#include <gtest/gtest.h>

#include <chrono>
#include <thread>
#include <vector>

#include "can_device_peer.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/protocol/can_codec.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

namespace pc = protocol::can;

class CanDeviceConformance : public CanDevicePeerTest {
 protected:
  // n sensor frames with bad checksums: a babbling node's, each refused by the device.
  void SendBadChecksums(int n) {
    for (int i = 0; i < n; ++i) {
      can_frame f{};
      ASSERT_EQ(pc::Encode(pc::SensorMotion{9.0, 0.0, 9, static_cast<std::uint8_t>(i & 15)}, &f),
                pc::Reject::kNone);
      f.data[7] ^= 0x5A;
      PeerSend(f);
    }
  }
};

TEST_F(CanDeviceConformance, DataThatWaitedInTheSocketKeepTheirArrivalStamps) {
  const std::int64_t before = common::MonotonicNs();
  SendMotion(4.0, 0.4, 1, 0);
  const std::int64_t sent = common::MonotonicNs();
  std::this_thread::sleep_for(std::chrono::milliseconds(40));  // the firmware was stalled
  SensorFrame frame;
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  EXPECT_GE(frame[Input::kVelocity].stamp_ns, before - 100'000);  // wall -> monotonic conversion
  // Stamped when it arrived, so the watchdog sees a 40 ms old sample, not a fresh one.
  EXPECT_LE(frame[Input::kVelocity].stamp_ns, sent)
      << "stamped " << (frame[Input::kVelocity].stamp_ns - sent) / 1000 << " us after it arrived";
}

TEST_F(CanDeviceConformance, ABacklogIsDrainedToTheNewestFrame) {
  constexpr int kBacklog = 100;  // 100 ms of motion frames behind a stalled firmware
  for (int i = 0; i < kBacklog; ++i) {
    SendMotion(0.01 * i, 0.0, static_cast<std::uint16_t>(i), static_cast<std::uint8_t>(i & 15));
  }
  SensorFrame frame;
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  EXPECT_EQ(device_->counters().rx_ok, static_cast<std::uint64_t>(kBacklog));
  EXPECT_DOUBLE_EQ(frame[Input::kVelocity].value, 0.01 * (kBacklog - 1));  // the newest sample
  IoError why = IoError::kNone;
  ASSERT_EQ(device_->Write(::mrd::test::NowIo(), {1.0, true, false, 0}, &why), IoStatus::kOk);
  pc::DriverCommand cmd;
  int commands = 0;
  for (const can_frame& f : PeerDrain()) {
    if (pc::Decode(f, &cmd) == pc::Reject::kNone) ++commands;
  }
  ASSERT_EQ(commands, 1);
  EXPECT_EQ(cmd.echo_seq, kBacklog - 1);
}

TEST_F(CanDeviceConformance, ABabblingNodeIsAFloodAndABusFault) {
  // Sensor IDs with bad checksums, far more than a healthy bus ever refuses, around the good
  // frames of the real sensor.
  SendMotion(2.0, 0.0, 1, 0);
  ASSERT_NO_FATAL_FAILURE(SendBadChecksums(200));
  SendMotion(3.0, 0.0, 2, 1);
  SensorFrame frame;
  IoError why = IoError::kNone;
  EXPECT_EQ(Read(&frame, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kOverflow);
  // Through the composite (the rest of the flood is still waiting): the can_bus cause, which
  // the watchdog turns into the safe state.
  FieldbusIo io;
  ASSERT_TRUE(io.Add(device_.get()));
  SensorFrame composite;
  EXPECT_EQ(io.Read(::mrd::test::NowIo(), &composite), IoStatus::kFault);
  EXPECT_EQ(composite.bus_faults, Watchdog::Bit(FaultCause::kCanBus));
  // Once the flood is drained, the good frame behind it is taken; the bus fault holds for
  // kFloodHoldNs after the last flooded period, then a clean bus is healthy again.
  int reads = 0;
  std::int64_t last_flood = common::MonotonicNs();
  while (reads < 100 && device_->counters().rx_ok < 2) {
    Read(&frame, &why);
    ++reads;
    last_flood = common::MonotonicNs();
  }
  EXPECT_DOUBLE_EQ(frame[Input::kVelocity].value, 3.0);
  const IoStatus held = Read(&frame, &why);
  if (common::MonotonicNs() - last_flood < CanDevice::kFloodHoldNs / 2) {
    EXPECT_EQ(held, IoStatus::kFault);
    EXPECT_EQ(why, IoError::kOverflow);
  }
  std::this_thread::sleep_for(std::chrono::nanoseconds(CanDevice::kFloodHoldNs + 10'000'000));
  EXPECT_EQ(Read(&frame, &why), IoStatus::kNoData);
  // A few refused frames are not a flood.
  ASSERT_NO_FATAL_FAILURE(SendBadChecksums(CanDevice::kMaxRejectsPerRead));
  EXPECT_EQ(Read(&frame, &why), IoStatus::kNoData);
}

TEST_F(CanDeviceConformance, NoDrivingCommandLeavesOnASampleOlderThanMaxAge) {
  CanConfig c = AllRouted();
  c.max_age_ns = 5'000'000;
  Make(c);
  SendMotion(1.0, 0.0, 77, 0);
  SensorFrame frame;
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  IoError why = IoError::kNone;
  ASSERT_EQ(device_->Write(::mrd::test::NowIo(), {1.5, true, false, 0}, &why),
            IoStatus::kOk);  // fresh: driven
  // The tick is held up between the watchdog's check and the write (a stopped process).
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(device_->Write(::mrd::test::NowIo(), {1.5, true, false, 1}, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kTimeout);
  // The safe command the loop then sends goes out.
  EXPECT_EQ(device_->Write(::mrd::test::NowIo(), {0.0, false, true, 1}, &why), IoStatus::kOk);
  std::vector<pc::DriverCommand> commands;
  for (const can_frame& f : PeerDrain()) {
    pc::DriverCommand m;
    if (pc::Decode(f, &m) == pc::Reject::kNone) commands.push_back(m);
  }
  ASSERT_EQ(commands.size(), 2U);
  EXPECT_FALSE(commands[0].safe);
  EXPECT_TRUE(commands[1].safe);
  EXPECT_FALSE(commands[1].enable);
  EXPECT_EQ(device_->counters().tx_failed, 1U);
}

TEST_F(CanDeviceConformance, ADriverFaultInDriverStatusAssertsTheFaultLine) {
  SendMotion(1.0, 0.0, 1, 0);
  SensorFrame frame;
  ASSERT_EQ(Read(&frame), IoStatus::kOk);
  EXPECT_FALSE(frame.fault_line);
  can_frame f{};
  ASSERT_EQ(pc::Encode(pc::DriverStatus{1.2, 0, 0}, &f), pc::Reject::kNone);
  PeerSend(f);
  frame = SensorFrame{};
  Read(&frame);
  EXPECT_FALSE(frame.fault_line);  // a healthy driver's status
  EXPECT_DOUBLE_EQ(device_->driver_current(), 1.2);
  std::uint8_t counter = 1;
  for (std::uint8_t bit : {pc::kFaultOvercurrent, pc::kFaultOvertemperature, pc::kFaultUndervoltage,
                           pc::kFaultHeartbeatLost, pc::kFaultCoilOpen}) {
    ASSERT_EQ(pc::Encode(pc::DriverStatus{0.0, bit, counter}, &f), pc::Reject::kNone);
    counter = static_cast<std::uint8_t>((counter + 1) & 15);
    PeerSend(f);
    frame = SensorFrame{};
    Read(&frame);
    EXPECT_TRUE(frame.fault_line) << "fault bit " << int{bit};
    // It holds until a status says otherwise (the driver sends one every 100 ms).
    frame = SensorFrame{};
    Read(&frame);
    EXPECT_TRUE(frame.fault_line);
    ASSERT_EQ(pc::Encode(pc::DriverStatus{0.0, 0, counter}, &f), pc::Reject::kNone);
    counter = static_cast<std::uint8_t>((counter + 1) & 15);
    PeerSend(f);
    frame = SensorFrame{};
    Read(&frame);
    EXPECT_FALSE(frame.fault_line);
  }
  // The fault line is the watchdog's fault_line cause: the safe state.
  ASSERT_EQ(pc::Encode(pc::DriverStatus{0.0, 0xFF, 11}, &f), pc::Reject::kNone);
  PeerSend(f);
  FieldbusIo io;
  ASSERT_TRUE(io.Add(device_.get()));
  SensorFrame composite;
  io.Read(::mrd::test::NowIo(), &composite);
  EXPECT_TRUE(composite.fault_line);
}

}  // namespace
}  // namespace mrd::firmware
