#include "mrd/firmware/model_runtime.hpp"

#include <cstring>

namespace mrd::firmware {

template <class T>
Error BasicModelRuntime<T>::Configure(const CoefficientTable& table) {
  Error e = table.Validate();
  if (e != Error::kOk) return e;
  const BasicModel<T> model = ModelAs<T>(table.model);
  e = model.Validate();  // a number beyond T's range
  if (e != Error::kOk) return e;
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
  table_ = table;
  model_ = model;
  v_channel_ = v;
  x_channel_ = x;
  raw_.fill(T(0));
  runner_.Reset();
  return Error::kOk;
}

template <class T>
void BasicModelRuntime<T>::Begin(T v, T x) {
  if (v_channel_ >= 0) raw_[static_cast<std::size_t>(v_channel_)] = v;
  if (x_channel_ >= 0) raw_[static_cast<std::size_t>(x_channel_)] = x;
  raw_[table_.input_channel] = T(0);
  runner_.Begin(raw_);
}

template <class T>
void BasicModelRuntime<T>::Seed(T v, T x, T E, T f) {
  Begin(v, x);
  runner_.SetInput(table_.input_channel, E);
  runner_.Finish(f);
}

template <class T>
T BasicModelRuntime<T>::ForceAt(T E) {
  runner_.SetInput(table_.input_channel, E);
  return runner_.Evaluate();
}

template <class T>
T BasicModelRuntime<T>::Finish(T E) {
  const T f = ForceAt(E);
  runner_.Finish(f);
  return f;
}

template class BasicModelRuntime<double>;
template class BasicModelRuntime<float>;

}  // namespace mrd::firmware
