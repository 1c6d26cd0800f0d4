#include "mrd/protocol/can_signal.hpp"

#include <cmath>

namespace mrd::protocol {
namespace {

// Payload bit (DBC numbering) of the signal's k-th bit counted from its least significant
// bit; -1 when it leaves a 64-bit payload.
int BitOf(const SignalLayout& s, int k) {
  if (s.order == ByteOrder::kIntel) {
    const int b = s.start_bit + k;
    return b < 64 ? b : -1;
  }
  // Motorola: walk from the MSB (start_bit) down length-1-k steps of the sawtooth.
  int b = s.start_bit;
  for (int i = 0; i < s.length - 1 - k; ++i) {
    b = (b % 8 == 0) ? b + 15 : b - 1;
    if (b >= 64) return -1;
  }
  return b;
}

bool LimitsSet(const SignalLayout& s) { return !(s.min == 0.0 && s.max == 0.0); }

}  // namespace

bool SignalMask(const SignalLayout& s, std::uint64_t* mask) {
  if (s.length < 1 || s.length > 64) return false;
  std::uint64_t m = 0;
  for (int k = 0; k < s.length; ++k) {
    const int b = BitOf(s, k);
    if (b < 0) return false;
    m |= std::uint64_t{1} << b;
  }
  *mask = m;
  return true;
}

bool SignalFits(const SignalLayout& s, int dlc) {
  std::uint64_t m = 0;
  if (dlc < 0 || dlc > 8 || !SignalMask(s, &m)) return false;
  return dlc == 8 || (m >> (8 * dlc)) == 0;
}

std::int64_t ExtractRaw(const std::uint8_t* data, const SignalLayout& s) {
  std::uint64_t raw = 0;
  for (int k = 0; k < s.length; ++k) {
    const int b = BitOf(s, k);
    if (b < 0) break;
    if ((data[b / 8] >> (b % 8)) & 1U) raw |= std::uint64_t{1} << k;
  }
  if (s.is_signed && s.length < 64 && ((raw >> (s.length - 1)) & 1U)) {
    raw |= ~std::uint64_t{0} << s.length;  // sign extension
  }
  return static_cast<std::int64_t>(raw);
}

void InsertRaw(std::uint8_t* data, const SignalLayout& s, std::int64_t raw) {
  const auto u = static_cast<std::uint64_t>(raw);
  for (int k = 0; k < s.length; ++k) {
    const int b = BitOf(s, k);
    if (b < 0) break;
    const auto bit = static_cast<std::uint8_t>(1U << (b % 8));
    if ((u >> k) & 1U) {
      data[b / 8] = static_cast<std::uint8_t>(data[b / 8] | bit);
    } else {
      data[b / 8] = static_cast<std::uint8_t>(data[b / 8] & ~bit);
    }
  }
}

SignalError DecodeSignal(const std::uint8_t* data, const SignalLayout& s, double* physical) {
  const std::int64_t raw = ExtractRaw(data, s);
  const double v =
      s.is_signed ? static_cast<double>(raw) : static_cast<double>(static_cast<std::uint64_t>(raw));
  *physical = v * s.factor + s.offset;
  if (LimitsSet(s) && (*physical < s.min || *physical > s.max)) return SignalError::kOutOfRange;
  return SignalError::kNone;
}

SignalError EncodeSignal(std::uint8_t* data, const SignalLayout& s, double physical) {
  if (!std::isfinite(physical)) return SignalError::kNotFinite;
  if (LimitsSet(s) && (physical < s.min || physical > s.max)) return SignalError::kOutOfRange;
  const double r = std::nearbyint((physical - s.offset) / s.factor);
  // The field's raw range (64-bit fields: within what a double holds exactly enough).
  const double lo = s.is_signed ? -std::ldexp(1.0, s.length - 1) : 0.0;
  const double hi =
      s.is_signed ? std::ldexp(1.0, s.length - 1) - 1.0 : std::ldexp(1.0, s.length) - 1.0;
  if (!(r >= lo && r <= hi) || std::fabs(r) >= 9.2e18) return SignalError::kOutOfRange;
  InsertRaw(data, s, static_cast<std::int64_t>(r));
  return SignalError::kNone;
}

}  // namespace mrd::protocol
