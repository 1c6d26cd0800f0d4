// The Modbus register map (docs/modbus_registers.md): addresses, word order, scaling, the
// sentinels and the refusals of out-of-range values and reserved codes.
#include "mrd/protocol/modbus_map.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>

namespace mrd::protocol::modbus {
namespace {

TEST(ModbusMap, BlocksFitTheMapAndDoNotOverlap) {
  EXPECT_LE(kSensorBase + kSensorCount, kCommandBase);
  EXPECT_LE(kCommandBase + kCommandCount, kMapSize);
  EXPECT_LE(kSensorCount, 125);   // one read request (function 0x03 limit)
  EXPECT_LE(kCommandCount, 123);  // one write request (function 0x10 limit)
}

TEST(ModbusMap, SensorRegistersHoldDocumentedScalingHighWordFirst) {
  SensorBlock s;
  s.seq = 0x12345678;
  s.velocity = -12.3456;     // 1e-4 cm/s -> -123456 = 0xFFFE1DC0
  s.displacement = 0.98765;  // 1e-5 cm   -> 98765 = 0x000181CD
  s.demand = 1234.56;        // 1e-2 N    -> 123456 = 0x0001E240
  s.body_velocity = 7.0;     // -> 70000 = 0x00011170
  s.force = -0.01;           // -> -1 = 0xFFFFFFFF
  s.fault_line = true;
  std::uint16_t r[kSensorCount] = {};
  ASSERT_EQ(EncodeSensors(s, r), MapError::kOk);
  EXPECT_EQ(r[0], 0x1234);
  EXPECT_EQ(r[1], 0x5678);
  EXPECT_EQ(r[2], 0xFFFE);
  EXPECT_EQ(r[3], 0x1DC0);
  EXPECT_EQ(r[4], 0x0001);
  EXPECT_EQ(r[5], 0x81CD);
  EXPECT_EQ(r[6], 0x0001);
  EXPECT_EQ(r[7], 0xE240);
  EXPECT_EQ(r[8], 0x0001);
  EXPECT_EQ(r[9], 0x1170);
  EXPECT_EQ(r[10], 0xFFFF);
  EXPECT_EQ(r[11], 0xFFFF);
  EXPECT_EQ(r[12], kFaultLineBit);

  SensorBlock d;
  ASSERT_EQ(DecodeSensors(r, &d), MapError::kOk);
  EXPECT_EQ(d.seq, s.seq);
  EXPECT_NEAR(d.velocity, s.velocity, 0.5e-4);
  EXPECT_NEAR(d.displacement, s.displacement, 0.5e-5);
  EXPECT_NEAR(d.demand, s.demand, 0.5e-2);
  EXPECT_NEAR(d.body_velocity, s.body_velocity, 0.5e-4);
  EXPECT_NEAR(d.force, s.force, 0.5e-2);
  EXPECT_TRUE(d.fault_line);
  EXPECT_FALSE(d.driver_fault);
}

TEST(ModbusMap, OutOfRangeOrNonFiniteSensorValuesAreNotEncoded) {
  std::uint16_t r[kSensorCount] = {};
  SensorBlock s;
  s.velocity = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(EncodeSensors(s, r), MapError::kOutOfRange);
  s.velocity = 0.0;
  s.displacement = 1e6;  // > 21474 cm
  EXPECT_EQ(EncodeSensors(s, r), MapError::kOutOfRange);
  s.displacement = 0.0;
  s.force = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(EncodeSensors(s, r), MapError::kOutOfRange);
}

TEST(ModbusMap, ReservedFaultBitsAreRefused) {
  std::uint16_t r[kSensorCount] = {};
  r[kFaults] = 0x0004;
  SensorBlock d;
  d.seq = 99;
  EXPECT_EQ(DecodeSensors(r, &d), MapError::kReservedBits);
  EXPECT_EQ(d.seq, 99U);  // untouched
  r[kFaults] = kDriverFaultBit;
  ASSERT_EQ(DecodeSensors(r, &d), MapError::kOk);
  EXPECT_TRUE(d.driver_fault);
}

TEST(ModbusMap, CommandRoundTripsWithSentinels) {
  CommandBlock c;
  c.echo = 0xCAFE0001;
  c.has_set_point = true;
  c.set_point = 1.234;
  c.enable_driven = true;
  c.enable = true;
  c.heartbeat = 0xBEEF;
  c.has_status = true;
  c.safe = false;
  c.causes = 0x0041;
  c.ticks = 70000;
  std::uint16_t r[kCommandCount] = {};
  ASSERT_EQ(EncodeCommand(c, r), MapError::kOk);
  EXPECT_EQ(r[kEcho], 0xCAFE);
  EXPECT_EQ(r[kEcho + 1], 0x0001);
  EXPECT_EQ(r[kSetPoint], 1234);
  EXPECT_EQ(r[kEnable], 1);
  EXPECT_EQ(r[kHeartbeat], 0xBEEF);
  EXPECT_EQ(r[kState], kStateStatusBit);
  EXPECT_EQ(r[kCauses], 0x0041);
  EXPECT_EQ(r[kTicks], 0x0001);
  EXPECT_EQ(r[kTicks + 1], 0x1170);
  CommandBlock d;
  ASSERT_EQ(DecodeCommand(r, &d), MapError::kOk);
  EXPECT_EQ(d.echo, c.echo);
  EXPECT_TRUE(d.has_set_point);
  EXPECT_NEAR(d.set_point, 1.234, 1e-12);
  EXPECT_TRUE(d.enable_driven);
  EXPECT_TRUE(d.enable);
  EXPECT_FALSE(d.safe);
  EXPECT_EQ(d.ticks, 70000U);

  CommandBlock none;  // nothing routed to this bus
  none.safe = true;
  ASSERT_EQ(EncodeCommand(none, r), MapError::kOk);
  EXPECT_EQ(r[kSetPoint], kNoSetPoint);
  EXPECT_EQ(r[kEnable], kEnableNotDriven);
  EXPECT_EQ(r[kState], kStateSafeBit);
  ASSERT_EQ(DecodeCommand(r, &d), MapError::kOk);
  EXPECT_FALSE(d.has_set_point);
  EXPECT_FALSE(d.enable_driven);
  EXPECT_FALSE(d.enable);
  EXPECT_TRUE(d.safe);
}

TEST(ModbusMap, SetPointOutsideItsFieldIsRefused) {
  std::uint16_t r[kCommandCount] = {};
  CommandBlock c;
  c.has_set_point = true;
  c.set_point = 40.0;  // > 32.767 V
  EXPECT_EQ(EncodeCommand(c, r), MapError::kOutOfRange);
  c.set_point = -32.768;  // the sentinel's raw value
  EXPECT_EQ(EncodeCommand(c, r), MapError::kOutOfRange);
  c.set_point = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(EncodeCommand(c, r), MapError::kOutOfRange);
  c.set_point = -0.5;  // negative but representable: the receiver's invariant check sees it
  EXPECT_EQ(EncodeCommand(c, r), MapError::kOk);
}

TEST(ModbusMap, UnknownEnableAndStateCodesAreRefused) {
  std::uint16_t r[kCommandCount] = {};
  CommandBlock d;
  r[kEnable] = 2;
  EXPECT_EQ(DecodeCommand(r, &d), MapError::kReservedBits);
  r[kEnable] = 0;
  r[kState] = 0x0100;
  EXPECT_EQ(DecodeCommand(r, &d), MapError::kReservedBits);
}

}  // namespace
}  // namespace mrd::protocol::modbus
