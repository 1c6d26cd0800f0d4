#include "mrd/common/model_check.hpp"

#include <cmath>
#include <cstring>

namespace mrd {

Error ModelCheck::error() const {
  switch (problem) {
    case ModelProblem::kNone:
      return Error::kOk;
    case ModelProblem::kNoChannels:
    case ModelProblem::kTooManyChannels:
    case ModelProblem::kTooManyRegressors:
    case ModelProblem::kTooManyTerms:
    case ModelProblem::kTooManyFactors:
      return Error::kCapacityExceeded;
    case ModelProblem::kChannelName:
    case ModelProblem::kChannelNameRepeated:
      return Error::kInvalidArgument;
    case ModelProblem::kChannelScaleNonFinite:
    case ModelProblem::kRegressorExponent:
    case ModelProblem::kCoefficient:
    case ModelProblem::kVoltageNonFinite:
    case ModelProblem::kEnvelopeNonFinite:
    case ModelProblem::kInvertibilityNonFinite:
      return Error::kNonFinite;
    case ModelProblem::kOutputChannel:
    case ModelProblem::kChannelScale:
    case ModelProblem::kRegressorChannel:
    case ModelProblem::kRegressorTransform:
    case ModelProblem::kAbsPowExponent:
    case ModelProblem::kLowPass:
    case ModelProblem::kSaturation:
    case ModelProblem::kFactorRegressor:
    case ModelProblem::kFactorDelay:
    case ModelProblem::kFactorPower:
    case ModelProblem::kOutputAtDelayZero:
    case ModelProblem::kInputChannel:
    case ModelProblem::kVoltageRange:
    case ModelProblem::kEnvelopeRange:
    case ModelProblem::kInvertibilityCount:
      return Error::kOutOfRange;
  }
  return Error::kInvalidArgument;
}

template <class T>
ModelCheck CheckModel(const BasicModel<T>& m) {
  auto at = [](ModelProblem p, std::size_t index, int count = 0) {
    return ModelCheck{p, static_cast<std::uint8_t>(index), count};
  };
  if (m.num_channels == 0) return at(ModelProblem::kNoChannels, 0);
  if (m.num_channels > kMaxChannels) return at(ModelProblem::kTooManyChannels, 0, m.num_channels);
  if (m.num_regressors > kMaxRegressors) {
    return at(ModelProblem::kTooManyRegressors, 0, m.num_regressors);
  }
  if (m.num_terms > kMaxTerms) return at(ModelProblem::kTooManyTerms, 0, m.num_terms);
  if (m.output_channel >= m.num_channels) return at(ModelProblem::kOutputChannel, 0);
  for (std::size_t c = 0; c < m.num_channels; ++c) {
    const char* name = m.channel_names[c].data();
    if (std::memchr(name, '\0', m.channel_names[c].size()) == nullptr || *name == '\0') {
      return at(ModelProblem::kChannelName, c);
    }
    for (const char* p = name; *p != '\0'; ++p) {
      if (*p < 0x20 || *p > 0x7e) return at(ModelProblem::kChannelName, c);  // printable ASCII
    }
    if (!std::isfinite(m.scales[c].offset) || !std::isfinite(m.scales[c].scale)) {
      return at(ModelProblem::kChannelScaleNonFinite, c);
    }
    if (!(m.scales[c].scale >= T(kMinChannelScale)) || m.scales[c].scale > T(kMaxChannelScale) ||
        std::fabs(m.scales[c].offset) > T(kMaxChannelOffset)) {
      return at(ModelProblem::kChannelScale, c);
    }
    for (std::size_t d = 0; d < c; ++d) {
      if (std::strcmp(m.channel_names[c].data(), m.channel_names[d].data()) == 0) {
        return at(ModelProblem::kChannelNameRepeated, c, static_cast<int>(d));
      }
    }
  }
  for (std::size_t r = 0; r < m.num_regressors; ++r) {
    const BasicRegressor<T>& reg = m.regressors[r];
    if (reg.channel >= m.num_channels) return at(ModelProblem::kRegressorChannel, r);
    if (static_cast<std::uint8_t>(reg.transform) > static_cast<std::uint8_t>(kLastTransform)) {
      return at(ModelProblem::kRegressorTransform, r);
    }
    if (!std::isfinite(reg.exponent)) return at(ModelProblem::kRegressorExponent, r);
    if (reg.transform == Transform::kAbsPow && !(reg.exponent > T(0))) {
      return at(ModelProblem::kAbsPowExponent, r);
    }
    if (reg.transform == Transform::kLowPass &&
        (!(reg.exponent > T(0)) || reg.exponent > static_cast<T>(kMaxLowPassTau) ||
         reg.channel == m.output_channel)) {
      return at(ModelProblem::kLowPass, r);
    }
    if ((reg.transform == Transform::kTanh || reg.transform == Transform::kClip) &&
        !(reg.exponent > T(0))) {
      return at(ModelProblem::kSaturation, r);
    }
  }
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    const Term& term = m.terms[i];
    if (term.num_factors > kMaxFactors)
      return at(ModelProblem::kTooManyFactors, i, term.num_factors);
    for (const Factor& f : term.active()) {
      if (f.regressor >= m.num_regressors) return at(ModelProblem::kFactorRegressor, i);
      if (f.delay > kMaxDelay) return at(ModelProblem::kFactorDelay, i, f.delay);
      if (f.power == 0 || f.power > kMaxPower) return at(ModelProblem::kFactorPower, i, f.power);
      if (m.regressors[f.regressor].channel == m.output_channel && f.delay == 0) {
        return at(ModelProblem::kOutputAtDelayZero, i);
      }
    }
    if (!std::isfinite(m.coefficients[i])) return at(ModelProblem::kCoefficient, i);
  }
  return {};
}

template ModelCheck CheckModel(const BasicModel<double>&);
template ModelCheck CheckModel(const BasicModel<float>&);

ModelCheck CheckTable(const CoefficientTable& t) {
  const ModelCheck m = CheckModel(t.model);
  if (!m.ok()) return m;
  if (t.input_channel >= t.model.num_channels || t.input_channel == t.model.output_channel) {
    return {ModelProblem::kInputChannel, t.input_channel, 0};
  }
  if (!std::isfinite(t.e_min) || !std::isfinite(t.e_max)) {
    return {ModelProblem::kVoltageNonFinite, 0, 0};
  }
  if (!(t.e_min < t.e_max) || t.e_min < 0.0 || t.e_max > kMaxCommandVoltage) {
    return {ModelProblem::kVoltageRange, 0, 0};
  }
  if (t.has_envelope) {
    for (std::size_t c = 0; c < t.model.num_channels; ++c) {
      const ChannelRange& r = t.envelope[c];
      const auto at = static_cast<std::uint8_t>(c);
      if (!std::isfinite(r.min) || !std::isfinite(r.max)) {
        return {ModelProblem::kEnvelopeNonFinite, at, 0};
      }
      if (!(r.min <= r.max)) return {ModelProblem::kEnvelopeRange, at, 0};
    }
  }
  if (t.has_invertibility) {
    if (!std::isfinite(t.invertibility.worst_slope)) {
      return {ModelProblem::kInvertibilityNonFinite, 0, 0};
    }
    if (t.invertibility.failing > t.invertibility.states) {
      return {ModelProblem::kInvertibilityCount, 0, static_cast<int>(t.invertibility.failing)};
    }
  }
  return {};
}

}  // namespace mrd
