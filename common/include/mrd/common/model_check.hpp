#pragma once
// The one validation of models and coefficient tables, with the reason as a code: the decoder,
// Model::Validate, CoefficientTable::Validate and the firmware map it to an Error; mrd export
// formats it in words (host/src/table_export.cpp). No allocation.

#include <cstddef>
#include <cstdint>
#include <span>

#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"

namespace mrd {

// Bounds of a channel's normalisation s = (raw - offset) / scale, in raw units: beyond them
// the normalised values leave any range a model is evaluated in (an offset of 1e308 or a
// scale of 5e-324 make every period's force non-finite).
inline constexpr double kMaxChannelOffset = 1e6;
inline constexpr double kMinChannelScale = 1e-6;
inline constexpr double kMaxChannelScale = 1e6;

enum class ModelProblem : std::uint8_t {
  kNone = 0,
  kNoChannels,             // num_channels == 0
  kTooManyChannels,        // num_channels > kMaxChannels (count)
  kTooManyRegressors,      // num_regressors > kMaxRegressors (count)
  kTooManyTerms,           // num_terms > kMaxTerms (count)
  kOutputChannel,          // output_channel >= num_channels
  kChannelName,            // channel (index) name without NUL, empty or not printable ASCII
  kChannelScaleNonFinite,  // channel (index) offset or scale not finite
  kChannelScale,           // channel (index) |offset| > kMaxChannelOffset or scale outside
                           // [kMinChannelScale, kMaxChannelScale]
  kChannelNameRepeated,    // channel (index) has the name of channel (count) before it
  kRegressorChannel,       // regressor (index) reads no channel
  kRegressorTransform,     // regressor (index) has an unknown transform
  kRegressorExponent,      // regressor (index) exponent not finite
  kAbsPowExponent,         // regressor (index) abs_pow exponent <= 0
  kLowPass,            // regressor (index) low-pass tau out of (0, kMaxLowPassTau] or on the output
  kSaturation,         // regressor (index) tanh scale or clip limit <= 0
  kTooManyFactors,     // term (index) has count > kMaxFactors factors
  kFactorRegressor,    // term (index) uses no regressor
  kFactorDelay,        // term (index) uses delay (count) > kMaxDelay
  kFactorPower,        // term (index) uses power (count) outside 1 ... kMaxPower
  kOutputAtDelayZero,  // term (index) reads the output at delay 0
  kCoefficient,        // coefficient (index) not finite
  kInputChannel,       // table input channel missing or the output
  kVoltageNonFinite,   // table e_min or e_max not finite
  kVoltageRange,       // table e_min >= e_max, or outside [0, kMaxCommandVoltage]
  kEnvelopeNonFinite,  // table envelope of channel (index) not finite
  kEnvelopeRange,      // table envelope of channel (index) has min > max
  kInvertibilityNonFinite,  // table invertibility record: worst slope not finite
  kInvertibilityCount,      // table invertibility record: failing (count) > states
};

struct ModelCheck {
  ModelProblem problem = ModelProblem::kNone;
  std::uint8_t index = 0;  // channel, regressor or term the problem is in
  int count = 0;           // the offending count, delay or power
  bool ok() const { return problem == ModelProblem::kNone; }
  // The Error the shared and firmware code report for it (kOk for kNone).
  Error error() const;
};

// First problem of a model, in a fixed order (capacities, output, channels, regressors,
// terms). T: double or float (instantiated for both).
template <class T>
ModelCheck CheckModel(const BasicModel<T>& model);
// CheckModel, then the input channel, the voltage range, the envelope and the invertibility
// record (when present).
ModelCheck CheckTable(const CoefficientTable& table);

// Why DecodeTable refused an image, for messages. No allocation.
struct TableDiagnosis {
  Error error = Error::kOk;  // what DecodeTable returns
  ModelCheck check;          // a content problem (CheckTable), else kNone
  bool stray_byte = false;   // a byte the encoder writes as zero is not (reserved, unused slot)
  std::size_t byte = 0;      // its offset
  std::uint8_t byte_value = 0;
  std::size_t size = 0;    // the image's size [bytes]
  CoefficientTable table;  // as decoded, when the counts were in range (names the values)
};
// DecodeTable, with *why filled in (also on success: error kOk).
Result<CoefficientTable> DecodeTable(std::span<const std::uint8_t> bytes, TableDiagnosis* why);

}  // namespace mrd
