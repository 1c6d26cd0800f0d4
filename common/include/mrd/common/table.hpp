#pragma once
// Coefficient table: the fixed-size, versioned, little-endian binary image of one model that
// travels from the host (`mrd export`) to the firmware (file or compiled-in header).
// Byte layout: docs/table_format.md. Encoding and decoding are explicit byte-wise
// little-endian (never a memcpy of a struct), so the image is the same on every target.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"

namespace mrd {

inline constexpr std::array<std::uint8_t, 4> kTableMagic = {'M', 'R', 'D', 'T'};
inline constexpr std::uint16_t kTableVersion = 1;

// Capacities of format version 1 (fixed; a model that exceeds one is refused at export).
inline constexpr std::size_t kTableChannels = kMaxChannels;      // 8
inline constexpr std::size_t kTableRegressors = kMaxRegressors;  // 16
inline constexpr std::size_t kTableTerms = kMaxTerms;            // 64
inline constexpr std::size_t kTableFactors = kMaxFactors;        // 4 per term

// Section offsets and sizes [bytes] (docs/table_format.md).
inline constexpr std::size_t kTableHeaderSize = 12;
inline constexpr std::size_t kTableCountsOffset = 12;
inline constexpr std::size_t kTableRangeOffset = 20;
inline constexpr std::size_t kTableChannelsOffset = 36;
inline constexpr std::size_t kTableChannelRecord = 32;
inline constexpr std::size_t kTableRegressorsOffset =
    kTableChannelsOffset + kTableChannels * kTableChannelRecord;  // 292
inline constexpr std::size_t kTableRegressorRecord = 16;
inline constexpr std::size_t kTableTermsOffset =
    kTableRegressorsOffset + kTableRegressors * kTableRegressorRecord;  // 548
inline constexpr std::size_t kTableTermRecord = 16;
inline constexpr std::size_t kTableCoefficientsOffset =
    kTableTermsOffset + kTableTerms * kTableTermRecord;  // 1572
inline constexpr std::size_t kTableCrcOffset =
    kTableCoefficientsOffset + kTableTerms * 8;          // 2084
inline constexpr std::size_t kTableSize = kTableCrcOffset + 4;  // 2088

using TableBytes = std::array<std::uint8_t, kTableSize>;

// One model plus what the firmware needs to invert it: which channel is the commanded input
// (normally "E") and its admissible range [e_min, e_max] in raw units [V].
struct CoefficientTable {
  Model model;
  std::uint8_t input_channel = 0;  // index of the inverted input (not the output)
  double e_min = 0.0;              // [V]
  double e_max = 2.25;             // [V], > e_min

  // Model::Validate() plus the input channel and the voltage range. kOk or the first problem
  // (kOutOfRange for a bad index or e_min >= e_max, kNonFinite for a non-finite bound).
  Error Validate() const;
};

// Highest total power of the inverted input at delay 0 in one term: the firmware solves a
// polynomial of at most this degree for the command.
inline constexpr int kMaxInputDegree = 4;

// Why a valid table cannot be inverted for its input (the one check of invertibility, used by
// the firmware's inverter and by mrd export).
enum class InversionProblem : std::uint8_t {
  kNone = 0,
  kTransform,  // the input enters at delay 0 through abs_pow or sign (not polynomial in E(k))
  kDegree,     // a term's total input power at delay 0 exceeds kMaxInputDegree
  kAbsent,     // the input does not enter at delay 0 at all
};
struct InversionCheck {
  InversionProblem problem = InversionProblem::kNone;
  std::uint8_t term = 0;  // term index of kTransform / kDegree
  int degree = 0;         // highest input degree (kNone), or the offending term's (kDegree)
};
// Assumes table.Validate() == kOk. Never allocates.
InversionCheck CheckInversion(const CoefficientTable& table);

// True when the factor is the input E(k) itself: the table's input channel at delay 0.
inline bool IsDirectInput(const CoefficientTable& table, const Factor& factor) {
  return factor.delay == 0 && table.model.regressors[factor.regressor].channel == table.input_channel;
}

// Encodes a table into its fixed-size image. Refuses (never truncates) a table that does not
// validate: kCapacityExceeded, kOutOfRange, kNonFinite, kInvalidArgument.
// No allocation; unused slots are written as zeros, so equal tables give equal bytes.
Result<TableBytes> EncodeTable(const CoefficientTable& table);

// Decodes and validates an image. Errors, checked in this order: kBadSize (shorter than the
// header), kBadMagic, kBadVersion, kBadSize (size field or span size != kTableSize), kBadCrc,
// kCapacityExceeded (a count over its capacity), kOutOfRange (an index, delay, power,
// transform, flag or the voltage range), kNonFinite (a coefficient, scale, exponent or bound),
// kInvalidArgument (a channel name without NUL). No allocation.
Result<CoefficientTable> DecodeTable(std::span<const std::uint8_t> bytes);

}  // namespace mrd
