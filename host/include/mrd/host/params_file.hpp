#pragma once
// Spencer damper parameters from a TOML file:
//
//   preset = "paper"     # optional base: "paper" (default) or "spencer1997"
//   c0a = 20.2           # any subset of the SpencerParams fields overrides the base
//
// Unknown keys, non-numeric values and invalid parameters throw InputError naming the file
// and line.

#include <string>

#include "mrd/sim/spencer_damper.hpp"

namespace mrd::host {

SpencerParams LoadSpencerParams(const std::string& path);

// Preset by name; throws InputError listing the valid names.
SpencerParams SpencerPreset(const std::string& name);

}  // namespace mrd::host
