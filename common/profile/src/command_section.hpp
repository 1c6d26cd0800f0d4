#pragma once
// The [command] section every profile kind shares: unit, calibration (a CSV relative to the
// profile's folder), min, max, slew_per_s (command_map.hpp). Start-up only; toml++ readers.

#include <toml++/toml.h>

#include <string>

#include "mrd/profile/command_map.hpp"

namespace mrd::profile {

struct CommandSection {
  std::string unit;                 // unchanged when the key is absent
  double min, max, slew_per_s = 0;  // unchanged when absent (the caller's defaults)
};

// Reads the keys of `t` into *out and the calibration into *map. false with *bad (the node to
// name in the error, by its line) and *why ("command.KEY: reason") on a bad or unknown key.
bool ReadCommandSection(const toml::table& t, const std::string& dir, CommandSection* out,
                        CommandMap* map, const toml::node** bad, std::string* why);

}  // namespace mrd::profile
