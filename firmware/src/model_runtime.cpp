#include "mrd/firmware/model_runtime.hpp"

#include <cstring>

namespace mrd::firmware {

Error ModelRuntime::Configure(const CoefficientTable& table) {
  const Error e = table.Validate();
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
  v_channel_ = v;
  x_channel_ = x;
  raw_.fill(0.0);
  runner_.Reset();
  return Error::kOk;
}

void ModelRuntime::Begin(double v, double x) {
  if (v_channel_ >= 0) raw_[static_cast<std::size_t>(v_channel_)] = v;
  if (x_channel_ >= 0) raw_[static_cast<std::size_t>(x_channel_)] = x;
  raw_[table_.input_channel] = 0.0;
  runner_.Begin(raw_);
}

void ModelRuntime::Seed(double v, double x, double E, double f) {
  Begin(v, x);
  runner_.SetInput(table_.input_channel, E);
  runner_.Finish(f);
}

double ModelRuntime::ForceAt(double E) {
  runner_.SetInput(table_.input_channel, E);
  return runner_.Evaluate();
}

double ModelRuntime::Finish(double E) {
  const double f = ForceAt(E);
  runner_.Finish(f);
  return f;
}

}  // namespace mrd::firmware
