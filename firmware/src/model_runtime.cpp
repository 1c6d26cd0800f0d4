#include "mrd/firmware/model_runtime.hpp"

#include <cmath>
#include <cstring>
#include <utility>

namespace mrd::firmware {
namespace {

// value held to [lo, hi]; *held set when it was outside (NaN passes unchanged).
template <class T>
T Hold(T value, T lo, T hi, bool* held) {
  if (value < lo) {
    *held = true;
    return lo;
  }
  if (value > hi) {
    *held = true;
    return hi;
  }
  return value;
}

// The model of an unconfigured runtime: no terms, no channels.
template <class T>
const std::shared_ptr<const BasicSharedModel<T>>& Unbound() {
  static const auto empty = std::make_shared<const BasicSharedModel<T>>();
  return empty;
}

}  // namespace

template <class T>
BasicModelRuntime<T>::BasicModelRuntime() : shared_(Unbound<T>()), runner_(shared_->model()) {}

template <class T>
Error BasicModelRuntime<T>::Configure(const CoefficientTable& table) {
  Error e = Error::kOk;
  auto shared = BasicSharedModel<T>::Load(table, &e);
  if (e != Error::kOk) return e;
  return Configure(std::move(shared));
}

template <class T>
Error BasicModelRuntime<T>::Configure(std::shared_ptr<const BasicSharedModel<T>> shared) {
  const CoefficientTable& table = shared->table();
  int v = -1;
  int x = -1;
  for (std::size_t c = 0; c < table.model.num_channels; ++c) {
    if (c == table.input_channel || c == table.model.output_channel) continue;
    const char* name = table.model.channel_names[c].data();
    if (std::strcmp(name, "v") == 0) {
      v = static_cast<int>(c);
    } else if (std::strcmp(name, "x") == 0) {
      x = static_cast<int>(c);
    } else {
      return Error::kInvalidArgument;
    }
  }
  shared_ = std::move(shared);
  runner_ = BasicModelRunner<T>(shared_->model());
  input_channel_ = shared_->table().input_channel;
  output_channel_ = shared_->table().model.output_channel;
  v_channel_ = v;
  x_channel_ = x;
  raw_.fill(T(0));
  runner_.Reset();
  envelope_ = false;
  ClearExcursions();
  return Error::kOk;
}

template <class T>
Error BasicModelRuntime<T>::SetEnvelope(bool use, double margin) {
  if (!std::isfinite(margin) || margin < 0.0) return Error::kOutOfRange;
  const CoefficientTable& table = shared_->table();
  envelope_ = use && table.has_envelope;
  if (!envelope_) return Error::kOk;
  for (std::size_t c = 0; c < table.model.num_channels; ++c) {
    const ChannelRange& r = table.envelope[c];
    const double m = margin * (r.max - r.min);
    lo_[c] = static_cast<T>(r.min - m);
    hi_[c] = static_cast<T>(r.max + m);
  }
  return Error::kOk;
}

template <class T>
void BasicModelRuntime<T>::Begin(T v, T x) {
  if (envelope_) {
    bool held = false;
    if (v_channel_ >= 0) {
      const auto c = static_cast<std::size_t>(v_channel_);
      v = Hold(v, lo_[c], hi_[c], &held);
    }
    if (x_channel_ >= 0) {
      const auto c = static_cast<std::size_t>(x_channel_);
      x = Hold(x, lo_[c], hi_[c], &held);
    }
    if (held) ++input_excursions_;
  }
  held_v_ = v;
  held_x_ = x;
  if (v_channel_ >= 0) raw_[static_cast<std::size_t>(v_channel_)] = v;
  if (x_channel_ >= 0) raw_[static_cast<std::size_t>(x_channel_)] = x;
  raw_[input_channel_] = T(0);
  runner_.Begin(raw_);
}

template <class T>
void BasicModelRuntime<T>::Seed(T v, T x, T E, T f) {
  Begin(v, x);
  runner_.SetInput(input_channel_, E);
  runner_.Finish(f);
}

template <class T>
T BasicModelRuntime<T>::ForceAt(T E) {
  runner_.SetInput(input_channel_, E);
  return runner_.Evaluate();
}

template <class T>
T BasicModelRuntime<T>::Finish(T E) {
  T f = ForceAt(E);
  if (envelope_) {
    bool held = false;
    const std::size_t c = output_channel_;
    f = Hold(f, lo_[c], hi_[c], &held);
    if (held) ++force_excursions_;
  }
  runner_.Finish(f);
  return f;
}

template class BasicModelRuntime<double>;
template class BasicModelRuntime<float>;

}  // namespace mrd::firmware
