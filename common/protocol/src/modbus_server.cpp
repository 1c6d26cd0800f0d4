#include "mrd/protocol/modbus_server.hpp"

#include <algorithm>

namespace mrd::protocol::modbus {
namespace {

ServerAnswer Exception(std::uint8_t function, std::uint8_t code, std::uint8_t* reply) {
  reply[0] = static_cast<std::uint8_t>(function | kExceptionFlag);
  reply[1] = code;
  ServerAnswer a;
  a.reply_len = 2;
  a.exception = true;
  return a;
}

int Get16(const std::uint8_t* p) { return (p[0] << 8) | p[1]; }

ServerAnswer Read(const std::uint8_t* pdu, int len, const std::uint16_t* regs,
                  std::uint8_t* reply) {
  if (len != 5) return Exception(pdu[0], kExIllegalValue, reply);
  const int address = Get16(pdu + 1), count = Get16(pdu + 3);
  if (count < 1 || count > kMaxReadCount) return Exception(pdu[0], kExIllegalValue, reply);
  if (address + count > kMapSize) return Exception(pdu[0], kExIllegalAddress, reply);
  reply[0] = kFcReadHolding;
  reply[1] = static_cast<std::uint8_t>(2 * count);
  for (int i = 0; i < count; ++i) {
    reply[2 + 2 * i] = static_cast<std::uint8_t>(regs[address + i] >> 8);
    reply[3 + 2 * i] = static_cast<std::uint8_t>(regs[address + i] & 0xFFU);
  }
  ServerAnswer a;
  a.reply_len = 2 + 2 * count;
  return a;
}

ServerAnswer Write(const std::uint8_t* pdu, int len, std::uint16_t* regs, std::uint8_t* reply) {
  if (len < 6) return Exception(pdu[0], kExIllegalValue, reply);
  const int address = Get16(pdu + 1), count = Get16(pdu + 3);
  if (count < 1 || count > kMaxWriteCount || pdu[5] != 2 * count || len != 6 + 2 * count) {
    return Exception(pdu[0], kExIllegalValue, reply);
  }
  if (address + count > kMapSize || address < kCommandBase) {  // the sensor block is read-only
    return Exception(pdu[0], kExIllegalAddress, reply);
  }
  std::uint16_t next[kMapSize];
  std::copy(regs, regs + kMapSize, next);
  for (int i = 0; i < count; ++i) {
    next[address + i] = static_cast<std::uint16_t>(Get16(pdu + 6 + 2 * i));
  }
  const bool command = address < kCommandBase + kCommandCount;
  CommandBlock c;
  if (command && DecodeCommand(next + kCommandBase, &c) != MapError::kOk) {
    return Exception(pdu[0], kExIllegalValue, reply);  // undefined codes: block unchanged
  }
  std::copy(next, next + kMapSize, regs);
  std::copy(pdu, pdu + 5, reply);  // function, address, count echoed
  ServerAnswer a;
  a.reply_len = 5;
  a.wrote = true;
  a.command = command;
  return a;
}

}  // namespace

ServerAnswer AnswerRequest(const std::uint8_t* pdu, int len, std::uint16_t regs[kMapSize],
                           std::uint8_t* reply) {
  if (len < 1) return Exception(0, kExIllegalFunction, reply);
  switch (pdu[0]) {
    case kFcReadHolding:
      return Read(pdu, len, regs, reply);
    case kFcWriteMultiple:
      return Write(pdu, len, regs, reply);
    default:
      return Exception(pdu[0], kExIllegalFunction, reply);
  }
}

}  // namespace mrd::protocol::modbus
