#include "mrd/common/model.hpp"

#include <cmath>
#include <cstring>

#include "mrd/common/model_check.hpp"

namespace mrd {

template <class T>
T ApplyTransform(Transform t, T exponent, std::type_identity_t<T> s) {
  switch (t) {
    case Transform::kIdentity:
      return s;
    case Transform::kAbsPow:
      return s == T(0) ? T(0) : std::pow(std::fabs(s), exponent);
    case Transform::kSign:
      return s > T(0) ? T(1) : (s < T(0) ? T(-1) : T(0));
    case Transform::kLowPass:
      return s;
    case Transform::kTanh:
      return std::tanh(s / exponent);
    case Transform::kClip:
      return s > exponent ? exponent : (s < -exponent ? -exponent : s);
  }
  return T(0);
}

double LowPassPole(double tau) { return std::exp(-1.0 / tau); }

template <class T>
Error BasicModel<T>::Validate() const {
  return CheckModel(*this).error();
}

template <class T>
std::uint8_t BasicModel<T>::MaxDelay() const {
  std::uint8_t d = 0;
  for (std::size_t i = 0; i < num_terms; ++i) {
    for (const Factor& f : terms[i].active()) d = f.delay > d ? f.delay : d;
  }
  return d;
}

template <class T>
int BasicModel<T>::ChannelIndex(const char* name) const {
  for (std::size_t c = 0; c < num_channels; ++c) {
    if (std::strcmp(channel_names[c].data(), name) == 0) return static_cast<int>(c);
  }
  return -1;
}

template <class T>
BasicModel<T> ModelAs(const Model& model) {
  BasicModel<T> out;
  out.num_channels = model.num_channels;
  out.output_channel = model.output_channel;
  out.channel_names = model.channel_names;
  for (std::size_t c = 0; c < kMaxChannels; ++c) {
    out.scales[c] = {static_cast<T>(model.scales[c].offset), static_cast<T>(model.scales[c].scale)};
  }
  out.num_regressors = model.num_regressors;
  for (std::size_t r = 0; r < kMaxRegressors; ++r) {
    const Regressor& reg = model.regressors[r];
    out.regressors[r] = {reg.channel, reg.transform, static_cast<T>(reg.exponent)};
  }
  out.num_terms = model.num_terms;
  out.terms = model.terms;
  for (std::size_t i = 0; i < kMaxTerms; ++i) {
    out.coefficients[i] = static_cast<T>(model.coefficients[i]);
  }
  return out;
}

template <class T>
void BasicRegressorHistory<T>::Reset(const BasicModel<T>& model) {
  for (std::size_t r = 0; r < kMaxRegressors; ++r) {
    const T zero = r < model.num_regressors ? ApplyTransform<T>(model.regressors[r].transform,
                                                                model.regressors[r].exponent, T(0))
                                            : T(0);
    values_[r].fill(zero);
    pole_[r] = r < model.num_regressors && model.regressors[r].transform == Transform::kLowPass
                   ? static_cast<T>(LowPassPole(static_cast<double>(model.regressors[r].exponent)))
                   : T(0);
  }
  head_ = 0;
}

template <class T>
T BasicRegressorHistory<T>::Transformed(const BasicRegressor<T>& reg, std::size_t r, T s) const {
  if (reg.transform != Transform::kLowPass) {
    return ApplyTransform<T>(reg.transform, reg.exponent, s);
  }
  return LowPassStep<T>(pole_[r], values_[r][(head_ + 1) % kDepth], s);  // from r(k-1)
}

template <class T>
void BasicRegressorHistory<T>::PushInputs(const BasicModel<T>& model,
                                          std::span<const T> normalised) {
  head_ = (head_ + kDepth - 1) % kDepth;
  for (std::size_t r = 0; r < model.num_regressors; ++r) {
    const BasicRegressor<T>& reg = model.regressors[r];
    values_[r][head_] =
        reg.channel == model.output_channel ? T(0) : Transformed(reg, r, normalised[reg.channel]);
  }
}

template <class T>
void BasicRegressorHistory<T>::Hold(const BasicModel<T>& model, std::span<const T> normalised) {
  for (std::size_t r = 0; r < model.num_regressors; ++r) {
    const BasicRegressor<T>& reg = model.regressors[r];
    const T s = normalised[reg.channel];
    values_[r].fill(reg.transform == Transform::kLowPass
                        ? s
                        : ApplyTransform<T>(reg.transform, reg.exponent, s));
  }
}

template <class T>
void BasicRegressorHistory<T>::SetOutput(const BasicModel<T>& model, T y_normalised) {
  for (std::size_t r = 0; r < model.num_regressors; ++r) {
    const BasicRegressor<T>& reg = model.regressors[r];
    if (reg.channel == model.output_channel) {
      values_[r][head_] = ApplyTransform<T>(reg.transform, reg.exponent, y_normalised);
    }
  }
}

template <class T>
void BasicRegressorHistory<T>::SetInput(const BasicModel<T>& model, std::size_t channel,
                                        T normalised) {
  if (channel == model.output_channel) return;
  for (std::size_t r = 0; r < model.num_regressors; ++r) {
    const BasicRegressor<T>& reg = model.regressors[r];
    if (reg.channel == channel) values_[r][head_] = Transformed(reg, r, normalised);
  }
}

template <class T>
T TermValue(const Term& term, const BasicRegressorHistory<T>& h) {
  T v = T(1);
  for (const Factor& f : term.active()) {
    const T base = h.value(f.regressor, f.delay);
    for (std::uint8_t p = 0; p < f.power; ++p) v *= base;
  }
  return v;
}

template <class T>
T EvaluateNormalised(const BasicModel<T>& model, const BasicRegressorHistory<T>& h) {
  T y = T(0);
  for (std::size_t i = 0; i < model.num_terms; ++i) {
    y += model.coefficients[i] * TermValue(model.terms[i], h);
  }
  return y;
}

template <class T>
void BasicModelRunner<T>::Reset() {
  history_.Reset(*model_);
}

template <class T>
void BasicModelRunner<T>::Begin(std::span<const T> raw) {
  for (std::size_t c = 0; c < model_->num_channels; ++c) {
    normalised_[c] = c == model_->output_channel ? T(0) : Normalise(model_->scales[c], raw[c]);
  }
  history_.PushInputs(*model_, normalised_);
}

template <class T>
void BasicModelRunner<T>::Finish(T y_raw) {
  history_.SetOutput(*model_, Normalise(model_->scales[model_->output_channel], y_raw));
}

template <class T>
void BasicModelRunner<T>::Seed(std::span<const T> raw) {
  Begin(raw);
  Finish(raw[model_->output_channel]);
}

template <class T>
void BasicModelRunner<T>::SetInput(std::size_t channel, T raw) {
  if (channel >= model_->num_channels || channel == model_->output_channel) return;
  normalised_[channel] = Normalise(model_->scales[channel], raw);
  history_.SetInput(*model_, channel, normalised_[channel]);
}

template <class T>
T BasicModelRunner<T>::Evaluate() const {
  return Denormalise(model_->scales[model_->output_channel], EvaluateNormalised(*model_, history_));
}

template <class T>
T BasicModelRunner<T>::Step(std::span<const T> raw) {
  Begin(raw);
  const T y = Evaluate();
  Finish(y);
  return y;
}

// The two scalar types: double (host, table, firmware by default) and float (MRD_REAL=float).
#define MRD_INSTANTIATE_MODEL(T)                                                           \
  template T ApplyTransform<T>(Transform, T, std::type_identity_t<T>);                     \
  template struct BasicModel<T>;                                                           \
  template BasicModel<T> ModelAs<T>(const Model&);                                         \
  template class BasicRegressorHistory<T>;                                                 \
  template T TermValue<T>(const Term&, const BasicRegressorHistory<T>&);                   \
  template T EvaluateNormalised<T>(const BasicModel<T>&, const BasicRegressorHistory<T>&); \
  template class BasicModelRunner<T>;
MRD_INSTANTIATE_MODEL(double)
MRD_INSTANTIATE_MODEL(float)
#undef MRD_INSTANTIATE_MODEL

}  // namespace mrd
