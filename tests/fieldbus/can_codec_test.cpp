// The CAN frame set (docs/mrd.dbc): round trips, every reject reason, the rolling counter.
#include "mrd/protocol/can_codec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace mrd::protocol::can {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(CanCodec, SensorMotionRoundTripKeepsValuesWithinHalfACount) {
  SensorMotion in{12.345, -0.9876, 54321, 9};
  can_frame f{};
  ASSERT_EQ(Encode(in, &f), Reject::kNone);
  EXPECT_EQ(f.can_id, kSensorMotionId);
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.data[7], Checksum(f));
  SensorMotion out;
  ASSERT_EQ(Decode(f, &out), Reject::kNone);
  EXPECT_NEAR(out.velocity, in.velocity, 0.005);
  EXPECT_NEAR(out.displacement, in.displacement, 0.0005);
  EXPECT_EQ(out.seq, 54321);
  EXPECT_EQ(out.counter, 9);
}

TEST(CanCodec, LayoutIsLittleEndianAsInTheDbc) {
  can_frame f{};
  ASSERT_EQ(Encode(SensorMotion{-1.0, 0.258, 0x1234, 3}, &f), Reject::kNone);
  // -1.0 cm/s = -100 counts = 0xFF9C; 0.258 cm = 258 counts = 0x0102.
  EXPECT_EQ(f.data[0], 0x9C);
  EXPECT_EQ(f.data[1], 0xFF);
  EXPECT_EQ(f.data[2], 0x02);
  EXPECT_EQ(f.data[3], 0x01);
  EXPECT_EQ(f.data[4], 0x34);
  EXPECT_EQ(f.data[5], 0x12);
  EXPECT_EQ(f.data[6] & 0x0F, 3);
}

// Bitwise CRC-8/SAE-J1850, written independently of the codec.
std::uint8_t ReferenceCrc(const std::uint8_t* bytes, std::size_t n) {
  std::uint8_t crc = 0xFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= bytes[i];
    for (int k = 0; k < 8; ++k) {
      crc = static_cast<std::uint8_t>((crc & 0x80) != 0 ? (crc << 1) ^ 0x1D : crc << 1);
    }
  }
  return static_cast<std::uint8_t>(crc ^ 0xFF);
}

TEST(CanCodec, ChecksumIsCrc8SaeJ1850OverIdAndData) {
  const std::uint8_t check[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  ASSERT_EQ(ReferenceCrc(check, sizeof check), 0x4B);  // the catalogue's check value
  can_frame f{};
  f.can_id = kSensorForceId;  // 0x101: ID bytes 0x01, 0x01
  f.len = 8;
  for (int i = 0; i < 8; ++i) f.data[i] = static_cast<std::uint8_t>(0x10 * i + 3);
  const std::uint8_t covered[9] = {0x01,      0x01,      f.data[0], f.data[1], f.data[2],
                                   f.data[3], f.data[4], f.data[5], f.data[6]};
  EXPECT_EQ(Checksum(f), ReferenceCrc(covered, sizeof covered));
  // Same data under another ID: another checksum (the ID is covered).
  can_frame g = f;
  g.can_id = kSensorMotionId;
  EXPECT_NE(Checksum(g), Checksum(f));
}

TEST(CanCodec, SensorForceDriverCommandHeartbeatStatusRoundTrip) {
  can_frame f{};
  ASSERT_EQ(Encode(SensorForce{-1234.5, 7.25, 2000.0, 15}, &f), Reject::kNone);
  SensorForce sf;
  ASSERT_EQ(Decode(f, &sf), Reject::kNone);
  EXPECT_DOUBLE_EQ(sf.demand, -1234.5);
  EXPECT_DOUBLE_EQ(sf.body_velocity, 7.25);
  EXPECT_DOUBLE_EQ(sf.force, 2000.0);
  EXPECT_EQ(sf.counter, 15);

  ASSERT_EQ(Encode(DriverCommand{2.25, true, true, false, 777, 4}, &f), Reject::kNone);
  DriverCommand dc;
  ASSERT_EQ(Decode(f, &dc), Reject::kNone);
  EXPECT_DOUBLE_EQ(dc.volts, 2.25);
  EXPECT_TRUE(dc.enable);
  EXPECT_TRUE(dc.enable_valid);
  EXPECT_FALSE(dc.safe);
  EXPECT_EQ(dc.echo_seq, 777);
  EXPECT_EQ(dc.counter, 4);

  ASSERT_EQ(Encode(Heartbeat{true, 11}, &f), Reject::kNone);
  EXPECT_EQ(f.len, kHeartbeatDlc);
  Heartbeat hb;
  ASSERT_EQ(Decode(f, &hb), Reject::kNone);
  EXPECT_TRUE(hb.safe);
  EXPECT_EQ(hb.counter, 11);

  ASSERT_EQ(Encode(DriverStatus{1.5, kFaultOvertemperature | kFaultCoilOpen, 2}, &f),
            Reject::kNone);
  DriverStatus ds;
  ASSERT_EQ(Decode(f, &ds), Reject::kNone);
  EXPECT_DOUBLE_EQ(ds.current, 1.5);
  EXPECT_EQ(ds.faults, kFaultOvertemperature | kFaultCoilOpen);

  ASSERT_EQ(Encode(FirmwareStatus{true, 0x0141, 65535, 3, 200}, &f), Reject::kNone);
  FirmwareStatus fs;
  ASSERT_EQ(Decode(f, &fs), Reject::kNone);
  EXPECT_TRUE(fs.safe);
  EXPECT_EQ(fs.active_causes, 0x0141);
  EXPECT_EQ(fs.overruns, 65535);
  EXPECT_EQ(fs.safe_entries, 3);
  EXPECT_EQ(fs.sequence, 200);
}

TEST(CanCodec, EncodeRefusesNonFiniteAndOutOfRangeAndLeavesFrameAlone) {
  can_frame f{};
  f.can_id = 0x7FF;
  EXPECT_EQ(Encode(SensorMotion{kNaN, 0.0, 0, 0}, &f), Reject::kNonFinite);
  EXPECT_EQ(Encode(SensorMotion{0.0, std::numeric_limits<double>::infinity(), 0, 0}, &f),
            Reject::kNonFinite);
  EXPECT_EQ(Encode(SensorMotion{300.01, 0.0, 0, 0}, &f), Reject::kOutOfRange);
  EXPECT_EQ(Encode(SensorForce{0.0, 0.0, -15000.5, 0}, &f), Reject::kOutOfRange);
  EXPECT_EQ(Encode(DriverCommand{-0.001, false, false, true, 0, 0}, &f), Reject::kOutOfRange);
  EXPECT_EQ(Encode(DriverCommand{24.001, false, false, true, 0, 0}, &f), Reject::kOutOfRange);
  EXPECT_EQ(Encode(DriverCommand{kNaN, false, false, true, 0, 0}, &f), Reject::kNonFinite);
  EXPECT_EQ(Encode(DriverStatus{10.5, 0, 0}, &f), Reject::kOutOfRange);
  EXPECT_EQ(f.can_id, 0x7FFU);
  // The range limits themselves are encodable.
  EXPECT_EQ(Encode(SensorMotion{-300.0, 30.0, 0, 0}, &f), Reject::kNone);
  EXPECT_EQ(Encode(DriverCommand{24.0, false, false, true, 0, 0}, &f), Reject::kNone);
}

TEST(CanCodec, DecodeRejectsWrongDlc) {
  can_frame f{};
  ASSERT_EQ(Encode(SensorMotion{1.0, 1.0, 1, 1}, &f), Reject::kNone);
  SensorMotion m{99.0, 99.0, 9, 9};
  f.len = 7;
  EXPECT_EQ(Decode(f, &m), Reject::kWrongDlc);
  f.len = 0;
  EXPECT_EQ(Decode(f, &m), Reject::kWrongDlc);
  ASSERT_EQ(Encode(Heartbeat{false, 1}, &f), Reject::kNone);
  f.len = 8;
  Heartbeat hb;
  EXPECT_EQ(Decode(f, &hb), Reject::kWrongDlc);
  EXPECT_DOUBLE_EQ(m.velocity, 99.0);  // untouched
}

TEST(CanCodec, DecodeRejectsUnknownAndNonDataFrames) {
  can_frame f{};
  ASSERT_EQ(Encode(SensorMotion{1.0, 1.0, 1, 1}, &f), Reject::kNone);
  SensorMotion m;
  DriverCommand dc;
  EXPECT_EQ(Decode(f, &dc), Reject::kUnknownId);  // a motion frame is not a command
  can_frame g = f;
  g.can_id = 0x123;
  EXPECT_EQ(Classify(g), Message::kUnknown);
  EXPECT_EQ(Decode(g, &m), Reject::kUnknownId);
  g.can_id = kSensorMotionId | CAN_EFF_FLAG;
  EXPECT_EQ(Classify(g), Message::kUnknown);
  EXPECT_EQ(Decode(g, &m), Reject::kUnknownId);
  g.can_id = kSensorMotionId | CAN_RTR_FLAG;
  EXPECT_EQ(Decode(g, &m), Reject::kUnknownId);
  EXPECT_EQ(Classify(f), Message::kSensorMotion);
}

TEST(CanCodec, DecodeRejectsBadChecksumOnEverySealedFrame) {
  can_frame f{};
  SensorMotion m;
  ASSERT_EQ(Encode(SensorMotion{1.0, 1.0, 1, 1}, &f), Reject::kNone);
  f.data[0] ^= 0x01;  // one bit flipped in the payload
  EXPECT_EQ(Decode(f, &m), Reject::kBadChecksum);
  ASSERT_EQ(Encode(SensorMotion{1.0, 1.0, 1, 1}, &f), Reject::kNone);
  f.data[7] ^= 0x80;  // in the checksum itself
  EXPECT_EQ(Decode(f, &m), Reject::kBadChecksum);
  SensorForce sf;
  ASSERT_EQ(Encode(SensorForce{1.0, 1.0, 1.0, 1}, &f), Reject::kNone);
  f.data[6] ^= 0x10;
  EXPECT_EQ(Decode(f, &sf), Reject::kBadChecksum);
  DriverCommand dc;
  ASSERT_EQ(Encode(DriverCommand{1.0, true, true, false, 1, 1}, &f), Reject::kNone);
  f.data[2] ^= 0x04;
  EXPECT_EQ(Decode(f, &dc), Reject::kBadChecksum);
  Heartbeat hb;
  ASSERT_EQ(Encode(Heartbeat{false, 1}, &f), Reject::kNone);
  f.data[0] ^= 0x01;
  EXPECT_EQ(Decode(f, &hb), Reject::kBadChecksum);
  DriverStatus ds;
  ASSERT_EQ(Encode(DriverStatus{1.0, 0, 1}, &f), Reject::kNone);
  f.data[1] ^= 0x01;
  EXPECT_EQ(Decode(f, &ds), Reject::kBadChecksum);
}

// A well-formed frame (right checksum) with a raw value beyond the DBC range.
TEST(CanCodec, DecodeRejectsOutOfRangeValues) {
  can_frame f{};
  ASSERT_EQ(Encode(SensorMotion{0.0, 0.0, 1, 1}, &f), Reject::kNone);
  f.data[0] = 0x31;  // 30001 counts = 300.01 cm/s
  f.data[1] = 0x75;
  f.data[7] = Checksum(f);
  SensorMotion m;
  EXPECT_EQ(Decode(f, &m), Reject::kOutOfRange);
  ASSERT_EQ(Encode(DriverCommand{0.0, false, false, true, 0, 0}, &f), Reject::kNone);
  f.data[0] = 0xFF;  // 65.535 V
  f.data[1] = 0xFF;
  f.data[7] = Checksum(f);
  DriverCommand dc;
  EXPECT_EQ(Decode(f, &dc), Reject::kOutOfRange);
  ASSERT_EQ(Encode(SensorForce{0.0, 0.0, 0.0, 0}, &f), Reject::kNone);
  f.data[5] = 0x80;  // force -32768 counts = -16384 N
  f.data[4] = 0x00;
  f.data[7] = Checksum(f);
  SensorForce sf;
  EXPECT_EQ(Decode(f, &sf), Reject::kOutOfRange);
}

TEST(CanCodec, CounterCheckRejectsRepeatedAndStaleAndResynchronises) {
  CounterCheck c;
  EXPECT_EQ(c.Check(5), Reject::kNone);  // first frame after reset
  EXPECT_EQ(c.Check(5), Reject::kRepeatedCounter);
  EXPECT_EQ(c.Check(6), Reject::kNone);
  EXPECT_EQ(c.Check(8), Reject::kNone);           // one frame lost: still accepted
  EXPECT_EQ(c.Check(15), Reject::kNone);          // 7 ahead: the largest gap accepted
  EXPECT_EQ(c.Check(0), Reject::kNone);           // wraps 15 -> 0
  EXPECT_EQ(c.Check(14), Reject::kStaleCounter);  // behind (an old frame)
  EXPECT_EQ(c.Check(15), Reject::kNone);  // resynchronised to 14: the sender's next frame passes
  EXPECT_EQ(c.Check(7), Reject::kStaleCounter);  // 8 ahead counts as behind
  c.Reset();
  EXPECT_EQ(c.Check(3), Reject::kNone);
}

TEST(CanCodec, RejectNamesAreDistinct) {
  for (std::size_t i = 0; i < kNumRejects; ++i) {
    for (std::size_t j = i + 1; j < kNumRejects; ++j) {
      EXPECT_STRNE(RejectName(static_cast<Reject>(i)), RejectName(static_cast<Reject>(j)));
    }
  }
}

}  // namespace
}  // namespace mrd::protocol::can
