#pragma once
// Fixed-point scaling of physical values into bus fields (CAN signals, Modbus registers):
//   raw = round((value - offset) / scale),  value = raw * scale + offset
// with the field's width and signedness. Pure; real-time safe.

#include <cstdint>

namespace mrd::protocol {

struct FieldScale {
  double scale = 1.0;     // physical units per raw count (> 0)
  double offset = 0.0;    // physical value at raw 0
  int bits = 16;          // field width, 1..32
  bool is_signed = true;  // two's complement
};

// Encodes value; false (and *raw untouched) when it is non-finite or outside the field's
// range — a sender never wraps a value around. *raw holds the field's bits, zero-extended.
bool Encode(const FieldScale& f, double value, std::uint32_t* raw);
// Decodes the low `bits` bits of raw (sign-extended when signed).
double Decode(const FieldScale& f, std::uint32_t raw);

}  // namespace mrd::protocol
