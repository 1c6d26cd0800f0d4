#pragma once
// CRC-32 (IEEE 802.3: reflected polynomial 0xEDB88320, initial value and final XOR
// 0xFFFFFFFF), as used by zlib, PNG and Ethernet. Check value: Crc32("123456789") ==
// 0xCBF43926.

#include <cstdint>
#include <span>

namespace mrd {

// CRC-32 of bytes. Continue a running CRC by passing the previous result as `crc`.
// Real-time safe (table-driven, constexpr table, no allocation).
std::uint32_t Crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

}  // namespace mrd
