#include "mrd/host/params_file.hpp"

#include <fmt/format.h>

#include "mrd/host/input_error.hpp"
#include "mrd/params/spencer_params_file.hpp"

namespace mrd::host {

SpencerParams SpencerPreset(const std::string& name) {
  SpencerParams p;
  if (!SpencerParams::FromPreset(name, &p)) {
    throw InputError("", 0,
                     fmt::format("unknown preset '{}' (expected paper or spencer1997)", name));
  }
  return p;
}

// The parser is shared with the HIL harness (common/params).
SpencerParams LoadSpencerParams(const std::string& path) {
  SpencerParams p;
  params::ParamsError e;
  if (!params::LoadSpencerParamsFile(path, &p, &e)) throw InputError(path, e.line, e.reason);
  return p;
}

}  // namespace mrd::host
