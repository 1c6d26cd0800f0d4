// CANopen (CiA 301) frame payloads (canopen_codec.hpp).
#include "mrd/profile/canopen_codec.hpp"

namespace mrd::profile::canopen {
namespace {

void PutHeader(std::uint8_t cs, std::uint16_t index, std::uint8_t subindex, std::uint8_t out[8]) {
  out[0] = cs;
  out[1] = static_cast<std::uint8_t>(index & 0xFFU);
  out[2] = static_cast<std::uint8_t>(index >> 8);
  out[3] = subindex;
}

void PutLe32(std::uint32_t v, std::uint8_t* out) {
  for (int i = 0; i < 4; ++i) out[i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFU);
}

std::uint32_t Le32(const std::uint8_t* d) {
  return static_cast<std::uint32_t>(d[0]) | static_cast<std::uint32_t>(d[1]) << 8 |
         static_cast<std::uint32_t>(d[2]) << 16 | static_cast<std::uint32_t>(d[3]) << 24;
}

struct AbortText {
  std::uint32_t code;
  const char* text;
};
// CiA 301 v4.2, table 22 (SDO abort codes).
constexpr AbortText kAborts[] = {
    {0x05030000, "toggle bit not alternated"},
    {0x05040000, "SDO protocol timed out"},
    {0x05040001, "client/server command specifier not valid or unknown"},
    {0x05040002, "invalid block size"},
    {0x05040003, "invalid sequence number"},
    {0x05040004, "CRC error"},
    {0x05040005, "out of memory"},
    {0x06010000, "unsupported access to an object"},
    {0x06010001, "attempt to read a write only object"},
    {0x06010002, "attempt to write a read only object"},
    {0x06020000, "object does not exist in the object dictionary"},
    {0x06040041, "object cannot be mapped to the PDO"},
    {0x06040042, "the number and length of the objects to be mapped would exceed PDO length"},
    {0x06040043, "general parameter incompatibility reason"},
    {0x06040047, "general internal incompatibility in the device"},
    {0x06060000, "access failed due to a hardware error"},
    {0x06070010, "data type does not match, length of service parameter does not match"},
    {0x06070012, "data type does not match, length of service parameter too high"},
    {0x06070013, "data type does not match, length of service parameter too low"},
    {0x06090011, "sub-index does not exist"},
    {0x06090030, "value range of parameter exceeded"},
    {0x06090031, "value of parameter written too high"},
    {0x06090032, "value of parameter written too low"},
    {0x06090036, "maximum value is less than minimum value"},
    {0x060A0023, "resource not available: SDO connection"},
    {0x08000000, "general error"},
    {0x08000020, "data cannot be transferred or stored to the application"},
    {0x08000021,
     "data cannot be transferred or stored to the application because of local "
     "control"},
    {0x08000022,
     "data cannot be transferred or stored to the application because of the "
     "present device state"},
    {0x08000023,
     "object dictionary dynamic generation fails or no object dictionary is "
     "present"},
    {0x08000024, "no data available"},
};

}  // namespace

const char* NmtStateName(std::uint8_t state) {
  switch (state & 0x7FU) {
    case kStateBootUp:
      return "boot-up";
    case kStateStopped:
      return "stopped";
    case kStateOperational:
      return "operational";
    case kStatePreOperational:
      return "pre-operational";
    default:
      return "unknown";
  }
}

bool EncodeSdoDownload(std::uint16_t index, std::uint8_t subindex, int size, std::int64_t value,
                       std::uint8_t out[8]) {
  if (size != 1 && size != 2 && size != 4) return false;
  // 0x20 download initiate | n = 4 - size unused bytes << 2 | e (expedited) | s (size given).
  const auto cs = static_cast<std::uint8_t>(0x20U | static_cast<unsigned>(4 - size) << 2 | 0x03U);
  PutHeader(cs, index, subindex, out);
  const auto raw = static_cast<std::uint64_t>(value);
  for (int i = 0; i < 4; ++i) {
    out[4 + i] = i < size ? static_cast<std::uint8_t>((raw >> (8 * i)) & 0xFFU) : 0;
  }
  return true;
}

bool DecodeSdoDownloadRequest(const std::uint8_t* data, int len, std::uint16_t* index,
                              std::uint8_t* subindex, int* size, std::uint32_t* raw) {
  if (len < 8 || (data[0] & 0xE0U) != 0x20U || (data[0] & 0x02U) == 0) return false;
  *index = static_cast<std::uint16_t>(data[1] | data[2] << 8);
  *subindex = data[3];
  *size = (data[0] & 0x01U) != 0 ? 4 - ((data[0] >> 2) & 0x03U) : 4;
  std::uint32_t v = Le32(data + 4);
  if (*size < 4) v &= (1U << (8 * *size)) - 1U;
  *raw = v;
  return true;
}

void EncodeSdoDownloadAck(std::uint16_t index, std::uint8_t subindex, std::uint8_t out[8]) {
  PutHeader(0x60, index, subindex, out);
  PutLe32(0, out + 4);
}

void EncodeSdoAbort(std::uint16_t index, std::uint8_t subindex, std::uint32_t code,
                    std::uint8_t out[8]) {
  PutHeader(0x80, index, subindex, out);
  PutLe32(code, out + 4);
}

SdoReply DecodeSdoReply(const std::uint8_t* data, int len, std::uint16_t index,
                        std::uint8_t subindex, std::uint32_t* abort_code) {
  if (len < 8) return SdoReply::kOther;
  const auto at = static_cast<std::uint16_t>(data[1] | data[2] << 8);
  if (at != index || data[3] != subindex) return SdoReply::kOther;
  if (data[0] == 0x60) return SdoReply::kAck;
  if (data[0] == 0x80) {
    *abort_code = Le32(data + 4);
    return SdoReply::kAbort;
  }
  return SdoReply::kOther;
}

const char* SdoAbortText(std::uint32_t code) {
  for (const AbortText& a : kAborts) {
    if (a.code == code) return a.text;
  }
  return "unknown abort code";
}

}  // namespace mrd::profile::canopen
