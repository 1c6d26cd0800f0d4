#pragma once
// The command range [E_min, E_max] a coefficient table is exported for (`mrd export`): given on
// the command line, else the device profile's command range, else the range the
// identification data reached (the model file's envelope of the command, clamped to the
// buses' [0, kMaxCommandVoltage] V), else (model files without an envelope) [0, 2.25] V. A
// warning names both ranges when the data reached beyond the table's range (the model is not
// checked nor inverted there) or the table's range reaches beyond the data (the model
// extrapolates there).

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mrd/host/model_file.hpp"

namespace mrd::host {

struct CommandRange {
  double e_min = 0.0;  // [V]
  double e_max = 2.25;
  std::string source;                 // where it came from, in words
  std::vector<std::string> warnings;  // "warning: ..." lines
};

// The command range of a device profile (CAN, Modbus or PWM, firmware/profiles/): its
// [command] min/max mapped back to E through its calibration (none: the range is in E itself
// [V]). Throws InputError(path, line, reason) for a profile that does not load or has no
// command range.
std::pair<double, double> ProfileCommandRange(const std::string& path);

// The range by the rules above. input: the inverted channel; e_min / e_max: given on the
// command line; profile: a device profile path ("" none). Throws InputError for a profile
// that does not load.
CommandRange ChooseCommandRange(const ModelFile& m, const std::string& input,
                                std::optional<double> e_min, std::optional<double> e_max,
                                const std::string& profile);

}  // namespace mrd::host
