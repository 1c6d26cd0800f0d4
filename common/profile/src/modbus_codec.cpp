// The Modbus profile's codec (modbus_profile.hpp): request and reply PDUs of a profile's
// grouped requests, typed values with the profile's word order. Pure code for either side's
// real-time path: no allocation, no exceptions, no I/O.
#include <cfloat>
#include <cmath>
#include <cstring>

#include "mrd/profile/modbus_profile.hpp"

namespace mrd::profile {
namespace {

constexpr std::uint8_t kExceptionFlag = 0x80;

bool IsBit(ModbusTable t) { return t == ModbusTable::kCoil || t == ModbusTable::kDiscrete; }

void Put16(std::uint8_t* p, int v) {
  p[0] = static_cast<std::uint8_t>((v >> 8) & 0xFF);
  p[1] = static_cast<std::uint8_t>(v & 0xFF);
}
int Get16(const std::uint8_t* p) { return (p[0] << 8) | p[1]; }

// Raw words (w[0] at the lower address) -> physical value.
double Decode(const ModbusPoint& pt, std::uint16_t w0, std::uint16_t w1) {
  const std::uint32_t hi = pt.swapped ? w1 : w0, lo = pt.swapped ? w0 : w1;
  const std::uint32_t u32 = (hi << 16) | lo;
  double raw = 0.0;
  switch (pt.type) {
    case ModbusType::kInt16:
      raw = static_cast<std::int16_t>(w0);
      break;
    case ModbusType::kUint16:
      raw = w0;
      break;
    case ModbusType::kBit:
      raw = w0 != 0 ? 1.0 : 0.0;
      break;
    case ModbusType::kInt32:
      raw = static_cast<std::int32_t>(u32);
      break;
    case ModbusType::kUint32:
      raw = u32;
      break;
    case ModbusType::kFloat32: {
      float f = 0.0F;
      std::memcpy(&f, &u32, sizeof f);
      raw = f;
      break;
    }
  }
  return raw * pt.scale + pt.offset;
}

// Physical value -> raw words; false when the type cannot hold it.
bool Encode(const ModbusPoint& pt, double value, std::uint16_t* w0, std::uint16_t* w1) {
  if (!std::isfinite(value)) return false;
  const double raw = (value - pt.offset) / pt.scale;
  if (!std::isfinite(raw)) return false;
  std::uint32_t u32 = 0;
  switch (pt.type) {
    case ModbusType::kBit:
      *w0 = raw != 0.0 ? 1 : 0;
      return true;
    case ModbusType::kInt16:
    case ModbusType::kUint16: {
      const double r = std::nearbyint(raw);
      const double lo = pt.type == ModbusType::kInt16 ? -32768.0 : 0.0;
      const double hi = pt.type == ModbusType::kInt16 ? 32767.0 : 65535.0;
      if (r < lo || r > hi) return false;
      *w0 = static_cast<std::uint16_t>(static_cast<std::int32_t>(r) & 0xFFFF);
      return true;
    }
    case ModbusType::kInt32:
    case ModbusType::kUint32: {
      const double r = std::nearbyint(raw);
      const double lo = pt.type == ModbusType::kInt32 ? -2147483648.0 : 0.0;
      const double hi = pt.type == ModbusType::kInt32 ? 2147483647.0 : 4294967295.0;
      if (r < lo || r > hi) return false;
      u32 = pt.type == ModbusType::kInt32 ? static_cast<std::uint32_t>(static_cast<std::int32_t>(r))
                                          : static_cast<std::uint32_t>(r);
      break;
    }
    case ModbusType::kFloat32: {
      if (std::fabs(raw) > static_cast<double>(FLT_MAX)) return false;
      const auto f = static_cast<float>(raw);
      std::memcpy(&u32, &f, sizeof u32);
      break;
    }
  }
  const auto hi = static_cast<std::uint16_t>(u32 >> 16), lo = static_cast<std::uint16_t>(u32);
  *w0 = pt.swapped ? lo : hi;
  *w1 = pt.swapped ? hi : lo;
  return true;
}

}  // namespace

int ModbusProfile::MaxCount() const {
  int n = 1;
  for (const auto& r : reads) n = r.count > n ? r.count : n;
  for (const auto& r : writes) n = r.count > n ? r.count : n;
  return n;
}

int PutModbusRead(const ModbusRequest& r, std::uint8_t* pdu) {
  pdu[0] = r.function;
  Put16(pdu + 1, r.address);
  Put16(pdu + 3, r.count);
  return 5;
}

ModbusReply CheckModbusRead(const ModbusRequest& r, const std::uint8_t* pdu, int len,
                            std::uint8_t* exception) {
  if (len == 2 && pdu[0] == (r.function | kExceptionFlag)) {
    *exception = pdu[1];
    return ModbusReply::kException;
  }
  const int bytes = IsBit(r.table) ? (r.count + 7) / 8 : 2 * r.count;
  if (len < 2 || pdu[0] != r.function || pdu[1] != bytes || len != 2 + bytes) {
    return ModbusReply::kMalformed;
  }
  return ModbusReply::kOk;
}

double ModbusPointValue(const ModbusProfile& /*p: the point carries its word order*/,
                        const ModbusPoint& pt, const std::uint8_t* pdu) {
  const std::uint8_t* data = pdu + 2;
  if (IsBit(pt.table)) {
    const int i = pt.index;
    return Decode(pt, static_cast<std::uint16_t>((data[i / 8] >> (i % 8)) & 1U), 0);
  }
  const auto w0 = static_cast<std::uint16_t>(Get16(data + 2 * pt.index));
  const auto w1 = pt.count() == 2 ? static_cast<std::uint16_t>(Get16(data + 2 * pt.index + 2))
                                  : std::uint16_t{0};
  return Decode(pt, w0, w1);
}

bool PutModbusPoint(const ModbusProfile& /*p: the point carries its word order*/,
                    const ModbusPoint& pt, double value, std::uint16_t* words) {
  std::uint16_t w0 = 0, w1 = 0;
  if (!Encode(pt, value, &w0, &w1)) return false;
  words[pt.index] = w0;
  if (pt.count() == 2) words[pt.index + 1] = w1;
  return true;
}

bool StoreModbusPoint(const ModbusProfile& /*p: the point carries its word order*/,
                      const ModbusPoint& pt, double value, std::uint16_t* table_words) {
  std::uint16_t w0 = 0, w1 = 0;
  if (!Encode(pt, value, &w0, &w1)) return false;
  table_words[pt.address] = w0;
  if (pt.count() == 2) table_words[pt.address + 1] = w1;
  return true;
}

double LoadModbusPoint(const ModbusProfile& /*p: the point carries its word order*/,
                       const ModbusPoint& pt, const std::uint16_t* table_words) {
  return Decode(pt, table_words[pt.address],
                pt.count() == 2 ? table_words[pt.address + 1] : std::uint16_t{0});
}

int PutModbusWrite(const ModbusRequest& r, const std::uint16_t* words, std::uint8_t* pdu) {
  pdu[0] = r.function;
  Put16(pdu + 1, r.address);
  switch (r.function) {
    case 0x05:
      Put16(pdu + 3, words[0] != 0 ? 0xFF00 : 0x0000);
      return 5;
    case 0x06:
      Put16(pdu + 3, words[0]);
      return 5;
    case 0x0F: {
      const int bytes = (r.count + 7) / 8;
      Put16(pdu + 3, r.count);
      pdu[5] = static_cast<std::uint8_t>(bytes);
      std::memset(pdu + 6, 0, static_cast<std::size_t>(bytes));
      for (int i = 0; i < r.count; ++i) {
        if (words[i] != 0)
          pdu[6 + i / 8] = static_cast<std::uint8_t>(pdu[6 + i / 8] | (1U << (i % 8)));
      }
      return 6 + bytes;
    }
    default: {  // 0x10
      Put16(pdu + 3, r.count);
      pdu[5] = static_cast<std::uint8_t>(2 * r.count);
      for (int i = 0; i < r.count; ++i) Put16(pdu + 6 + 2 * i, words[i]);
      return 6 + 2 * r.count;
    }
  }
}

ModbusReply CheckModbusWrite(const ModbusRequest& r, const std::uint8_t* request_pdu,
                             const std::uint8_t* pdu, int len, std::uint8_t* exception) {
  if (len == 2 && pdu[0] == (r.function | kExceptionFlag)) {
    *exception = pdu[1];
    return ModbusReply::kException;
  }
  // 0x05 0x06 echo address and value, 0x0F 0x10 address and count: the request's bytes 1..4.
  if (len != 5 || pdu[0] != r.function || std::memcmp(pdu + 1, request_pdu + 1, 4) != 0) {
    return ModbusReply::kMalformed;
  }
  return ModbusReply::kOk;
}

}  // namespace mrd::profile
