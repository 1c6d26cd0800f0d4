#include "mrd/protocol/modbus_frame.hpp"

namespace mrd::protocol::modbus {
namespace {

void Put16(std::uint16_t v, std::uint8_t* p) {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v & 0xFFU);
}
std::uint16_t Get16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

}  // namespace

std::uint16_t Crc16(const std::uint8_t* data, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ data[i]);
    for (int b = 0; b < 8; ++b) {
      crc = (crc & 1U) != 0 ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001U)
                            : static_cast<std::uint16_t>(crc >> 1);
    }
  }
  return crc;
}

void PutMbap(const Mbap& h, std::uint8_t out[kMbapSize]) {
  Put16(h.transaction, out);
  Put16(h.protocol, out + 2);
  Put16(h.length, out + 4);
  out[6] = h.unit;
}

Mbap GetMbap(const std::uint8_t in[kMbapSize]) {
  return {Get16(in), Get16(in + 2), Get16(in + 4), in[6]};
}

int PutReadRequest(int address, int count, std::uint8_t* pdu) {
  pdu[0] = kFcReadHolding;
  Put16(static_cast<std::uint16_t>(address), pdu + 1);
  Put16(static_cast<std::uint16_t>(count), pdu + 3);
  return 5;
}

int PutWriteRequest(int address, const std::uint16_t* regs, int count, std::uint8_t* pdu) {
  pdu[0] = kFcWriteMultiple;
  Put16(static_cast<std::uint16_t>(address), pdu + 1);
  Put16(static_cast<std::uint16_t>(count), pdu + 3);
  pdu[5] = static_cast<std::uint8_t>(2 * count);
  for (int i = 0; i < count; ++i) Put16(regs[i], pdu + 6 + 2 * i);
  return 6 + 2 * count;
}

namespace {

// Exception reply to `function`, or kMalformed for a reply to another function.
Reply CheckHeader(const std::uint8_t* pdu, int len, std::uint8_t function,
                  std::uint8_t* exception) {
  if (len < 1) return Reply::kMalformed;
  if (pdu[0] == (function | kExceptionFlag)) {
    if (len != 2) return Reply::kMalformed;
    *exception = pdu[1];
    return Reply::kException;
  }
  return pdu[0] == function ? Reply::kOk : Reply::kMalformed;
}

}  // namespace

Reply CheckReadReply(const std::uint8_t* pdu, int len, int count, std::uint16_t* regs,
                     std::uint8_t* exception) {
  const Reply r = CheckHeader(pdu, len, kFcReadHolding, exception);
  if (r != Reply::kOk) return r;
  if (len != 2 + 2 * count || pdu[1] != 2 * count) return Reply::kMalformed;
  for (int i = 0; i < count; ++i) regs[i] = Get16(pdu + 2 + 2 * i);
  return Reply::kOk;
}

Reply CheckWriteReply(const std::uint8_t* pdu, int len, int address, int count,
                      std::uint8_t* exception) {
  const Reply r = CheckHeader(pdu, len, kFcWriteMultiple, exception);
  if (r != Reply::kOk) return r;
  if (len != 5 || Get16(pdu + 1) != address || Get16(pdu + 3) != count) return Reply::kMalformed;
  return Reply::kOk;
}

int RtuReplyLength(const std::uint8_t* adu, int have) {
  if (have < 2) return 0;
  const std::uint8_t f = adu[1];
  if ((f & kExceptionFlag) != 0) return 5;
  switch (f) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04:
    case 0x17:  // address, function, count, data
      return have < 3 ? 0 : 5 + adu[2];
    case 0x05:
    case 0x06:
    case 0x0F:
    case 0x10:
      return 8;
    case 0x16:
      return 10;
    default:
      return -1;
  }
}

int RtuRequestLength(const std::uint8_t* adu, int have) {
  if (have < 2) return 0;
  switch (adu[1]) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04:
    case 0x05:
    case 0x06:
    case 0x08:
      return 8;
    case 0x07:
    case 0x0B:
    case 0x0C:
    case 0x11:
      return 4;
    case 0x0F:
    case 0x10:  // address, function, start, count, byte count, data
      return have < 7 ? 0 : 9 + adu[6];
    case 0x14:
    case 0x15:
      return have < 3 ? 0 : 5 + adu[2];
    case 0x16:
      return 10;
    case 0x17:  // read start, count, write start, count, byte count, data
      return have < 11 ? 0 : 13 + adu[10];
    case 0x18:
      return 6;
    default:
      return -1;
  }
}

bool RtuCrcValid(const std::uint8_t* adu, int len) {
  if (len < 4) return false;
  const std::uint16_t crc = Crc16(adu, static_cast<std::size_t>(len - 2));
  return adu[len - 2] == (crc & 0xFFU) && adu[len - 1] == (crc >> 8);
}

int PutRtuCrc(std::uint8_t* adu, int len) {
  const std::uint16_t crc = Crc16(adu, static_cast<std::size_t>(len));
  adu[len] = static_cast<std::uint8_t>(crc & 0xFFU);
  adu[len + 1] = static_cast<std::uint8_t>(crc >> 8);
  return len + 2;
}

std::int64_t RtuFrameNs(int bytes, int baud, int data_bits, char parity, int stop_bits) {
  if (baud <= 0) return 0;
  const std::int64_t bits = 1 + data_bits + (parity == 'N' ? 0 : 1) + stop_bits;
  return static_cast<std::int64_t>(bytes) * bits * 1'000'000'000 / baud;
}

}  // namespace mrd::protocol::modbus
