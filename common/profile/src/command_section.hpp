#pragma once
// The [command] section every profile kind shares: unit, calibration (a CSV relative to the
// profile's folder), min, max, slew_per_s (command_map.hpp). Start-up only; toml++ readers.

#include <toml++/toml.h>

#include <string>

#include "mrd/profile/command_map.hpp"
#include "profile_context.hpp"

namespace mrd::profile {

struct CommandSection {
  std::string unit;                 // unchanged when the key is absent
  double min, max, slew_per_s = 0;  // unchanged when absent (the caller's defaults)
};

// Reads the keys of `t` into *out and the calibration into *map. false with *bad (the node to
// name in the error, by its line) and *why ("command.KEY: reason") on a bad or unknown key.
bool ReadCommandSection(const toml::table& t, const std::string& dir, CommandSection* out,
                        CommandMap* map, const toml::node** bad, std::string* why);

// [command] of a CAN or Modbus profile: ReadCommandSection into *unit and *map, then the range
// (min, max unbounded when absent) set on *map. false with c's error naming the bad key's line,
// or the section's for a range SetRange refuses.
bool ReadCommand(const ProfileContext& c, const toml::table& t, const std::string& dir,
                 std::string* unit, CommandMap* map);

// What the set-point's signal or register can carry, in the driver's unit: [lo, hi] and the
// smallest step (0: a float); `name` says which ("DriveRpdo1.TargetCurrent (drive.dbc:12)").
struct SetpointCarrier {
  std::string name;
  double lo = 0.0, hi = 0.0, step = 0.0;
};

// The command against its carrier, and the safe state proved from the profile alone: "" or
// the reason (the caller names the [command] line). Refused: a [command] min or max beyond
// what the carrier holds (the safe state would replace the very set-points beyond it); a
// calibration (without a range) reaching beyond it; and a safe state (E = 0 V: the firmware's
// shutdown, and its safe state at the default safe_voltage) that is not the driver's off
// (CommandMap::Off: a decreasing calibration, or one that does not start at the off value).
std::string CheckCommandCarrier(const CommandMap& map, const std::string& unit,
                                const SetpointCarrier& carrier, const char** key);
// CheckCommandCarrier for a profile whose root table is `root`: true when it passes, else c's
// error at the [command] key it names, or without one at the node `output_path` (the command
// output's role, "outputs.command").
bool CheckCommandCarrierAt(const ProfileContext& c, const toml::table& root, const CommandMap& map,
                           const std::string& unit, const SetpointCarrier& carrier,
                           const char* output_path);
// A number as the errors show it (up to 6 significant digits).
std::string ShowNumber(double v);

}  // namespace mrd::profile
