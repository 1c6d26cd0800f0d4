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
// Version 2 adds the operating envelope (flags bit 0, section before the CRC); version 3 the
// invertibility record (flags bit 1, after the envelope). Version 1 images (2088 bytes, no
// envelope) and version 2 images (2216 bytes, no invertibility record) still decode.
inline constexpr std::uint16_t kTableVersion = 3;
inline constexpr std::uint16_t kTableVersionV2 = 2;
inline constexpr std::uint16_t kTableVersionV1 = 1;
inline constexpr std::uint16_t kTableFlagEnvelope = 1;       // flags bit 0: envelope present
inline constexpr std::uint16_t kTableFlagInvertibility = 2;  // flags bit 1: record present

// Capacities of format versions 1 to 3 (fixed; a model that exceeds one is refused at export).
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
inline constexpr std::size_t kTableEnvelopeOffset =
    kTableCoefficientsOffset + kTableTerms * 8;          // 2084 (version 1: the CRC)
inline constexpr std::size_t kTableEnvelopeRecord = 16;  // min f64, max f64
inline constexpr std::size_t kTableInvertibilityOffset =
    kTableEnvelopeOffset + kTableChannels * kTableEnvelopeRecord;  // 2212 (version 2: the CRC)
inline constexpr std::size_t kTableInvertibilityRecord = 16;       // states u32, failing u32, f64
inline constexpr std::size_t kTableCrcOffset =
    kTableInvertibilityOffset + kTableInvertibilityRecord;                   // 2228
inline constexpr std::size_t kTableSize = kTableCrcOffset + 4;               // 2232
inline constexpr std::size_t kTableCrcOffsetV2 = kTableInvertibilityOffset;  // 2212
inline constexpr std::size_t kTableSizeV2 = kTableCrcOffsetV2 + 4;           // 2216
inline constexpr std::size_t kTableCrcOffsetV1 = kTableEnvelopeOffset;       // 2084
inline constexpr std::size_t kTableSizeV1 = kTableCrcOffsetV1 + 4;           // 2088

using TableBytes = std::array<std::uint8_t, kTableSize>;

// Highest command the buses carry [V] (CAN VoltageSetpoint [0, 24] V, docs/mrd.dbc): the
// input range [e_min, e_max] of a table lies in [0, kMaxCommandVoltage].
inline constexpr double kMaxCommandVoltage = 24.0;

// Range one channel covered in the identification data [raw units], min <= max.
struct ChannelRange {
  double min = 0.0;
  double max = 0.0;
};

// Invertibility of the model in its input over [e_min, e_max], as `mrd export` checked it
// (common/invertibility.hpp, host/invertibility.hpp: the states the identification data visited
// and a grid over the envelope): how many states, how many of them fail (the force falls as E
// rises in the dissipative direction, or turns back), and the lowest df/dE * sign(v) found
// [output unit per input unit; N/V]. failing <= states; worst_slope finite.
struct TableInvertibility {
  std::uint32_t states = 0;
  std::uint32_t failing = 0;
  double worst_slope = 0.0;
};

// One model plus what the firmware needs to invert it: which channel is the commanded input
// (normally "E") and its admissible range [e_min, e_max] in raw units [V]; optionally the
// operating envelope: per channel (inputs and the output force) the range the identification
// data covered, which the firmware holds the model's inputs to (with a margin); optionally the
// invertibility record.
struct CoefficientTable {
  Model model;
  std::uint8_t input_channel = 0;  // index of the inverted input (not the output)
  double e_min = 0.0;              // [V]
  double e_max = 2.25;             // [V], > e_min
  bool has_envelope = false;       // false: no envelope (version 1 image, or not recorded)
  std::array<ChannelRange, kMaxChannels> envelope{};  // per model channel; zeros when absent
  bool has_invertibility = false;      // false: not recorded (version 1 or 2 image, or not checked)
  TableInvertibility invertibility{};  // zeros when absent

  // Model::Validate() plus the input channel, the voltage range, the envelope and the
  // invertibility record. kOk or the first problem (kOutOfRange for a bad index, e_min >=
  // e_max, a range outside [0, kMaxCommandVoltage], an envelope min > max or more failing
  // states than states; kNonFinite for a non-finite bound or worst slope).
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
  return factor.delay == 0 &&
         table.model.regressors[factor.regressor].channel == table.input_channel;
}

// Encodes a table into its fixed-size image. Refuses (never truncates) a table that does not
// validate: kCapacityExceeded, kOutOfRange, kNonFinite, kInvalidArgument.
// No allocation; unused slots are written as zeros, so equal tables give equal bytes.
Result<TableBytes> EncodeTable(const CoefficientTable& table);

// Decodes and validates an image of version 3 (or 2: no invertibility record; or 1: no
// envelope either). Errors, checked in this order: kBadSize (shorter than the header),
// kBadMagic, kBadVersion (not 1, 2 or 3), kBadSize (size field or span size != the version's
// size), kBadCrc, kOutOfRange (a flag the version does not define),
// kCapacityExceeded (a count over its capacity), then the content (CheckTable): kOutOfRange
// (an index, delay, power, transform, normalisation or the voltage range), kNonFinite (a
// coefficient, scale, exponent or bound), kInvalidArgument (a channel name without NUL or
// repeated); last kOutOfRange for a byte the encoder writes as zero that is not (a reserved
// byte, an unused slot, a name byte after its NUL, the envelope without flag bit 0, the
// invertibility record without flag bit 1): a valid image is exactly EncodeTable's image of
// its table. No allocation. The reason in detail:
// DecodeTable(bytes, TableDiagnosis*) in model_check.hpp.
Result<CoefficientTable> DecodeTable(std::span<const std::uint8_t> bytes);

}  // namespace mrd
