#include "mrd/common/model.hpp"

#include <cmath>
#include <cstring>

#include "mrd/common/model_check.hpp"

namespace mrd {

double ApplyTransform(Transform t, double exponent, double s) {
  switch (t) {
    case Transform::kIdentity:
      return s;
    case Transform::kAbsPow:
      return s == 0.0 ? 0.0 : std::pow(std::fabs(s), exponent);
    case Transform::kSign:
      return s > 0.0 ? 1.0 : (s < 0.0 ? -1.0 : 0.0);
    case Transform::kLowPass:
      return s;
  }
  return 0.0;
}

double LowPassPole(double tau) { return std::exp(-1.0 / tau); }

Error Model::Validate() const { return CheckModel(*this).error(); }

std::uint8_t Model::MaxDelay() const {
  std::uint8_t d = 0;
  for (std::size_t i = 0; i < num_terms; ++i) {
    for (const Factor& f : terms[i].active()) d = f.delay > d ? f.delay : d;
  }
  return d;
}

int Model::ChannelIndex(const char* name) const {
  for (std::size_t c = 0; c < num_channels; ++c) {
    if (std::strcmp(channel_names[c].data(), name) == 0) return static_cast<int>(c);
  }
  return -1;
}

void RegressorHistory::Reset(const Model& model) {
  for (std::size_t r = 0; r < kMaxRegressors; ++r) {
    const double zero =
        r < model.num_regressors
            ? ApplyTransform(model.regressors[r].transform, model.regressors[r].exponent, 0.0)
            : 0.0;
    values_[r].fill(zero);
    pole_[r] = r < model.num_regressors && model.regressors[r].transform == Transform::kLowPass
                   ? LowPassPole(model.regressors[r].exponent)
                   : 0.0;
  }
  head_ = 0;
}

double RegressorHistory::Transformed(const Regressor& reg, std::size_t r, double s) const {
  if (reg.transform != Transform::kLowPass) return ApplyTransform(reg.transform, reg.exponent, s);
  return LowPassStep(pole_[r], values_[r][(head_ + 1) % kDepth], s);  // from r(k-1)
}

void RegressorHistory::PushInputs(const Model& model, std::span<const double> normalised) {
  head_ = (head_ + kDepth - 1) % kDepth;
  for (std::size_t r = 0; r < model.num_regressors; ++r) {
    const Regressor& reg = model.regressors[r];
    values_[r][head_] =
        reg.channel == model.output_channel ? 0.0 : Transformed(reg, r, normalised[reg.channel]);
  }
}

void RegressorHistory::SetOutput(const Model& model, double y_normalised) {
  for (std::size_t r = 0; r < model.num_regressors; ++r) {
    const Regressor& reg = model.regressors[r];
    if (reg.channel == model.output_channel) {
      values_[r][head_] = ApplyTransform(reg.transform, reg.exponent, y_normalised);
    }
  }
}

void RegressorHistory::SetInput(const Model& model, std::size_t channel, double normalised) {
  if (channel == model.output_channel) return;
  for (std::size_t r = 0; r < model.num_regressors; ++r) {
    const Regressor& reg = model.regressors[r];
    if (reg.channel == channel) values_[r][head_] = Transformed(reg, r, normalised);
  }
}

double TermValue(const Term& term, const RegressorHistory& h) {
  double v = 1.0;
  for (const Factor& f : term.active()) {
    const double base = h.value(f.regressor, f.delay);
    for (std::uint8_t p = 0; p < f.power; ++p) v *= base;
  }
  return v;
}

double EvaluateNormalised(const Model& model, const RegressorHistory& h) {
  double y = 0.0;
  for (std::size_t i = 0; i < model.num_terms; ++i) {
    y += model.coefficients[i] * TermValue(model.terms[i], h);
  }
  return y;
}

void ModelRunner::Reset() { history_.Reset(*model_); }

void ModelRunner::Begin(std::span<const double> raw) {
  for (std::size_t c = 0; c < model_->num_channels; ++c) {
    normalised_[c] = c == model_->output_channel ? 0.0 : Normalise(model_->scales[c], raw[c]);
  }
  history_.PushInputs(*model_, normalised_);
}

void ModelRunner::Finish(double y_raw) {
  history_.SetOutput(*model_, Normalise(model_->scales[model_->output_channel], y_raw));
}

void ModelRunner::Seed(std::span<const double> raw) {
  Begin(raw);
  Finish(raw[model_->output_channel]);
}

void ModelRunner::SetInput(std::size_t channel, double raw) {
  if (channel >= model_->num_channels || channel == model_->output_channel) return;
  normalised_[channel] = Normalise(model_->scales[channel], raw);
  history_.SetInput(*model_, channel, normalised_[channel]);
}

double ModelRunner::Evaluate() const {
  return Denormalise(model_->scales[model_->output_channel],
                     EvaluateNormalised(*model_, history_));
}

double ModelRunner::Step(std::span<const double> raw) {
  Begin(raw);
  const double y = Evaluate();
  Finish(y);
  return y;
}

}  // namespace mrd
