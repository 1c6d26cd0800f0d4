// The Modbus framing (mrd/protocol/modbus_frame.hpp) and the register server
// (mrd/protocol/modbus_server.hpp), pure: CRC-16 and frame lengths against the specification's
// examples, the client's reply checks, the server's exception codes, and the RTU wire times
// docs/modbus_registers.md quotes.
#include "mrd/protocol/modbus_frame.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "mrd/protocol/modbus_map.hpp"
#include "mrd/protocol/modbus_server.hpp"

namespace mrd::protocol::modbus {
namespace {

TEST(ModbusFrame, Crc16OfTheSensorBlockReadIsLowByteFirst) {
  // Read 13 holding registers at 0 from unit 1: 01 03 00 00 00 0D, CRC 84 0F on the wire.
  std::uint8_t adu[8] = {0x01, 0x03, 0x00, 0x00, 0x00, 0x0D};
  EXPECT_EQ(PutRtuCrc(adu, 6), 8);
  EXPECT_EQ(adu[6], 0x84);
  EXPECT_EQ(adu[7], 0x0F);
  EXPECT_TRUE(RtuCrcValid(adu, 8));
  adu[3] ^= 1;
  EXPECT_FALSE(RtuCrcValid(adu, 8));
}

TEST(ModbusFrame, MbapRoundTripsAndFramesOnlyPlausibleLengths) {
  std::uint8_t h[kMbapSize];
  PutMbap({0x1234, 0, 6, 7}, h);
  EXPECT_EQ(h[0], 0x12);
  EXPECT_EQ(h[1], 0x34);
  EXPECT_EQ(h[5], 6);
  const Mbap m = GetMbap(h);
  EXPECT_EQ(m.transaction, 0x1234);
  EXPECT_EQ(m.protocol, 0);
  EXPECT_EQ(m.length, 6);
  EXPECT_EQ(m.unit, 7);
  EXPECT_FALSE(MbapLengthValid(1));  // a unit id and no function
  EXPECT_TRUE(MbapLengthValid(2));
  EXPECT_TRUE(MbapLengthValid(254));
  EXPECT_FALSE(MbapLengthValid(255));
}

TEST(ModbusFrame, RtuLengthsComeFromTheFunction) {
  const std::uint8_t read_reply[3] = {1, 0x03, 26};
  EXPECT_EQ(RtuReplyLength(read_reply, 1), 0);
  EXPECT_EQ(RtuReplyLength(read_reply, 2), 0);  // the byte count is needed
  EXPECT_EQ(RtuReplyLength(read_reply, 3), 31);
  const std::uint8_t exception[2] = {1, 0x83};
  EXPECT_EQ(RtuReplyLength(exception, 2), 5);
  const std::uint8_t write_reply[2] = {1, 0x10};
  EXPECT_EQ(RtuReplyLength(write_reply, 2), 8);
  const std::uint8_t unknown[2] = {1, 0x41};
  EXPECT_EQ(RtuReplyLength(unknown, 2), -1);
  const std::uint8_t write_request[7] = {1, 0x10, 0, 32, 0, 9, 18};
  EXPECT_EQ(RtuRequestLength(write_request, 6), 0);
  EXPECT_EQ(RtuRequestLength(write_request, 7), 27);
  const std::uint8_t read_request[2] = {1, 0x03};
  EXPECT_EQ(RtuRequestLength(read_request, 2), 8);
  EXPECT_EQ(RtuRequestLength(unknown, 2), -1);
}

TEST(ModbusFrame, ClientChecksRepliesAgainstItsRequest) {
  std::uint16_t regs[2] = {};
  std::uint8_t ex = 0;
  const std::uint8_t ok[6] = {0x03, 4, 0x12, 0x34, 0xAB, 0xCD};
  EXPECT_EQ(CheckReadReply(ok, 6, 2, regs, &ex), Reply::kOk);
  EXPECT_EQ(regs[0], 0x1234);
  EXPECT_EQ(regs[1], 0xABCD);
  EXPECT_EQ(CheckReadReply(ok, 6, 3, regs, &ex), Reply::kMalformed);  // wrong count
  const std::uint8_t short_count[6] = {0x03, 2, 0x12, 0x34, 0xAB, 0xCD};
  EXPECT_EQ(CheckReadReply(short_count, 6, 2, regs, &ex), Reply::kMalformed);
  const std::uint8_t exception[2] = {0x83, 0x04};
  EXPECT_EQ(CheckReadReply(exception, 2, 2, regs, &ex), Reply::kException);
  EXPECT_EQ(ex, 0x04);
  EXPECT_EQ(CheckWriteReply(exception, 2, 32, 9, &ex), Reply::kMalformed);  // another function
  const std::uint8_t echo[5] = {0x10, 0, 32, 0, 9};
  EXPECT_EQ(CheckWriteReply(echo, 5, 32, 9, &ex), Reply::kOk);
  EXPECT_EQ(CheckWriteReply(echo, 5, 33, 9, &ex), Reply::kMalformed);
}

// The server's answer to one request: the exception code, or the reply's length.
int Answer(const std::vector<std::uint8_t>& pdu, std::uint16_t* regs, ServerAnswer* out = nullptr) {
  std::uint8_t reply[kMaxPdu];
  const ServerAnswer a = AnswerRequest(pdu.data(), static_cast<int>(pdu.size()), regs, reply);
  if (out != nullptr) *out = a;
  return a.exception ? -reply[1] : a.reply_len;
}

TEST(ModbusServer, AnswersTheDocumentedRequestsAndRefusesTheRestWithTheSpecCodes) {
  std::uint16_t regs[kMapSize] = {};
  regs[kCommandBase + kSetPoint] = kNoSetPoint;
  regs[kCommandBase + kEnable] = kEnableNotDriven;
  EXPECT_EQ(Answer({0x03, 0, 0, 0, 16}, regs), 2 + 32);
  EXPECT_EQ(Answer({0x03, 0, 47, 0, 1}, regs), 4);
  EXPECT_EQ(Answer({0x03, 0, 48, 0, 1}, regs), -kExIllegalAddress);
  EXPECT_EQ(Answer({0x03, 0, 0, 0, 0}, regs), -kExIllegalValue);
  EXPECT_EQ(Answer({0x03, 0, 0, 0, 126}, regs), -kExIllegalValue);
  EXPECT_EQ(Answer({0x03, 0, 0, 0}, regs), -kExIllegalValue);  // PDU too short
  for (int f : {0x01, 0x02, 0x04, 0x05, 0x06, 0x0F, 0x16, 0x17, 0x2B, 0x41}) {
    EXPECT_EQ(Answer({static_cast<std::uint8_t>(f), 0, 35, 0, 1}, regs), -kExIllegalFunction) << f;
  }
  // 0x10: the command block, whole or in part; never the sensor block.
  ServerAnswer a;
  EXPECT_EQ(Answer({0x10, 0, 34, 0, 2, 4, 0x03, 0xE8, 0, 1}, regs, &a), 5);
  EXPECT_TRUE(a.wrote && a.command);
  EXPECT_EQ(regs[kCommandBase + kSetPoint], 1000);
  EXPECT_EQ(regs[kCommandBase + kEnable], 1);
  EXPECT_EQ(Answer({0x10, 0, 45, 0, 1, 2, 0, 5}, regs, &a), 5);  // unused 41..47
  EXPECT_TRUE(a.wrote && !a.command);
  EXPECT_EQ(Answer({0x10, 0, 0, 0, 1, 2, 0, 5}, regs), -kExIllegalAddress);
  EXPECT_EQ(Answer({0x10, 0, 31, 0, 2, 4, 0, 0, 0, 0}, regs), -kExIllegalAddress);
  EXPECT_EQ(Answer({0x10, 0, 47, 0, 2, 4, 0, 0, 0, 0}, regs), -kExIllegalAddress);
  EXPECT_EQ(Answer({0x10, 0, 35, 0, 1, 4, 0, 0}, regs), -kExIllegalValue);  // byte count
  EXPECT_EQ(Answer({0x10, 0, 35, 0, 0, 0}, regs), -kExIllegalValue);        // quantity 0
  // Undefined codes: refused, the block as it was.
  EXPECT_EQ(Answer({0x10, 0, 35, 0, 1, 2, 0, 5}, regs), -kExIllegalValue);
  EXPECT_EQ(Answer({0x10, 0, 37, 0, 1, 2, 0, 4}, regs), -kExIllegalValue);
  EXPECT_EQ(regs[kCommandBase + kEnable], 1);
  EXPECT_EQ(regs[kCommandBase + kState], 0);
}

// docs/modbus_registers.md: at 115200 Bd (8N1, 10 bits per character) the sensor block read
// (8-byte request + 31-byte reply) takes 3.4 ms on the wire, the command write (27 + 8
// bytes) 3.0 ms.
TEST(ModbusFrame, RtuWireTimesAreTheDocumentedOnes) {
  EXPECT_NEAR(static_cast<double>(RtuFrameNs(8 + 31, 115200, 8, 'N', 1)) * 1e-6, 3.39, 0.01);
  EXPECT_NEAR(static_cast<double>(RtuFrameNs(27 + 8, 115200, 8, 'N', 1)) * 1e-6, 3.04, 0.01);
  EXPECT_EQ(RtuFrameNs(1, 9600, 8, 'E', 1), 11 * 1'000'000'000LL / 9600);  // parity bit
}

}  // namespace
}  // namespace mrd::protocol::modbus
