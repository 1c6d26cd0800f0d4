#pragma once
// Errors as values for common/ and firmware/ (no exceptions there).

#include <cstdint>
#include <utility>

namespace mrd {

// Every error the shared and firmware code can report. Stable numbering: it appears in logs
// and in the firmware's exit status.
enum class Error : std::uint8_t {
  kOk = 0,
  kInvalidArgument,
  kOutOfRange,
  kNonFinite,
  kBadMagic,
  kBadVersion,
  kBadSize,
  kBadCrc,
  kCapacityExceeded,
  kNotInvertible,
  kIo,
  kTimeout,
};

// Short, static, human-readable name of an error (never allocates).
const char* ErrorName(Error e);

// Value-or-error. T must be default-constructible; no exceptions, no allocation.
template <typename T>
class Result {
 public:
  Result(T value) : value_(std::move(value)), error_(Error::kOk) {}  // NOLINT: implicit
  Result(Error error) : value_(), error_(error) {}                   // NOLINT: implicit

  bool ok() const { return error_ == Error::kOk; }
  Error error() const { return error_; }
  const T& value() const { return value_; }
  T& value() { return value_; }

 private:
  T value_;
  Error error_;
};

}  // namespace mrd
