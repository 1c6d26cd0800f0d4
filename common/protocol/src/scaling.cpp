#include "mrd/protocol/scaling.hpp"

#include <cmath>

namespace mrd::protocol {
namespace {

std::int64_t MinRaw(const FieldScale& f) {
  return f.is_signed ? -(std::int64_t{1} << (f.bits - 1)) : 0;
}
std::int64_t MaxRaw(const FieldScale& f) {
  return f.is_signed ? (std::int64_t{1} << (f.bits - 1)) - 1 : (std::int64_t{1} << f.bits) - 1;
}

}  // namespace

bool Encode(const FieldScale& f, double value, std::uint32_t* raw) {
  if (!std::isfinite(value)) return false;
  const double r = std::round((value - f.offset) / f.scale);
  if (r < static_cast<double>(MinRaw(f)) || r > static_cast<double>(MaxRaw(f))) return false;
  const auto v = static_cast<std::int64_t>(r);
  const std::uint64_t mask = (std::uint64_t{1} << f.bits) - 1;
  *raw = static_cast<std::uint32_t>(static_cast<std::uint64_t>(v) & mask);
  return true;
}

double Decode(const FieldScale& f, std::uint32_t raw) {
  const std::uint64_t mask = (std::uint64_t{1} << f.bits) - 1;
  std::int64_t v = static_cast<std::int64_t>(raw & mask);
  if (f.is_signed && (v & (std::int64_t{1} << (f.bits - 1))) != 0) {
    v -= std::int64_t{1} << f.bits;
  }
  return static_cast<double>(v) * f.scale + f.offset;
}

}  // namespace mrd::protocol
