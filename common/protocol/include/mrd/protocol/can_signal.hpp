#pragma once
// One signal of a CAN message as a DBC file describes it (`SG_` line): where its bits are in
// the payload, how raw bits map to a physical value, and the range a receiver accepts. Pure
// code for the real-time path: no allocation, no exceptions, no I/O.
//
// Bit numbering is the DBC's: bit i is bit (i % 8) of byte i / 8 (LSB = 0).
//   Intel (little endian, "@1"): start_bit is the signal's least significant bit; the bits
//     follow upwards (bit i, i+1, ...), crossing into the next byte.
//   Motorola (big endian, "@0"): start_bit is the signal's most significant bit; the bits
//     follow downwards within a byte and continue at bit 7 of the next byte ("sawtooth").
// physical = raw * factor + offset, raw unsigned or two's complement over length bits.

#include <cstdint>

namespace mrd::protocol {

enum class ByteOrder : std::uint8_t { kIntel, kMotorola };

struct SignalLayout {
  std::uint16_t start_bit = 0;  // DBC start bit (see above)
  std::uint8_t length = 1;      // bits, 1..64
  ByteOrder order = ByteOrder::kIntel;
  bool is_signed = false;
  double factor = 1.0;  // != 0
  double offset = 0.0;
  double min = 0.0, max = 0.0;  // accepted physical range; min == max == 0: no limit (DBC)
};

enum class SignalError : std::uint8_t {
  kNone = 0,
  kOutOfRange,  // decoded value outside [min, max], or value to encode outside it / the field
  kNotFinite,   // value to encode is NaN or infinite
};

// True when every bit of the signal lies within a payload of dlc bytes.
bool SignalFits(const SignalLayout& s, int dlc);
// Marks the signal's bits in a 64-bit mask of the payload's bits (bit i of the mask = payload
// bit i in DBC numbering); false when it does not fit 8 bytes.
bool SignalMask(const SignalLayout& s, std::uint64_t* mask);

// Raw field value (sign-extended when signed) from / into a payload of at least 8 bytes' worth
// of the signal's bits. Insert leaves other bits unchanged.
std::int64_t ExtractRaw(const std::uint8_t* data, const SignalLayout& s);
void InsertRaw(std::uint8_t* data, const SignalLayout& s, std::int64_t raw);

// Physical value of the signal; kOutOfRange when outside [min, max] (the value is still set).
SignalError DecodeSignal(const std::uint8_t* data, const SignalLayout& s, double* physical);
// Writes the physical value (rounded to the nearest raw step); refuses, writing nothing, a
// non-finite value, one outside [min, max], or one whose raw value does not fit the field.
SignalError EncodeSignal(std::uint8_t* data, const SignalLayout& s, double physical);

}  // namespace mrd::protocol
