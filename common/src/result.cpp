#include "mrd/common/result.hpp"

namespace mrd {

const char* ErrorName(Error e) {
  switch (e) {
    case Error::kOk:
      return "ok";
    case Error::kInvalidArgument:
      return "invalid argument";
    case Error::kOutOfRange:
      return "value out of range";
    case Error::kNonFinite:
      return "non-finite value";
    case Error::kBadMagic:
      return "wrong magic";
    case Error::kBadVersion:
      return "unsupported format version";
    case Error::kBadSize:
      return "wrong size";
    case Error::kBadCrc:
      return "CRC mismatch";
    case Error::kCapacityExceeded:
      return "capacity exceeded";
    case Error::kNotInvertible:
      return "model not invertible in E";
    case Error::kIo:
      return "I/O error";
    case Error::kTimeout:
      return "timeout";
  }
  return "unknown error";
}

}  // namespace mrd
