#include "command_section.hpp"

#include <cmath>

namespace mrd::profile {

bool ReadCommandSection(const toml::table& t, const std::string& dir, CommandSection* out,
                        CommandMap* map, const toml::node** bad, std::string* why) {
  for (const auto& [k, v] : t) {
    const std::string key(k.str());
    const std::string full = "command." + key;
    *bad = &v;
    if (key == "unit") {
      const auto s = v.value<std::string>();
      if (!s || s->empty() || s->size() > 16) {
        *why = full + ": expected a short unit name";
        return false;
      }
      out->unit = *s;
    } else if (key == "calibration") {
      const auto s = v.value<std::string>();
      if (!s || s->empty()) {
        *why = full + ": expected the path of a CSV file";
        return false;
      }
      const std::string file = (*s)[0] == '/' ? *s : dir + "/" + *s;
      std::string reason;
      if (!map->LoadCalibration(file, &reason)) {
        *why = full + ": " + reason;
        return false;
      }
    } else if (key == "min" || key == "max" || key == "slew_per_s") {
      const auto d = v.value<double>();
      if (!d || !std::isfinite(*d)) {
        *why = full + ": expected a number";
        return false;
      }
      (key == "min" ? out->min : key == "max" ? out->max : out->slew_per_s) = *d;
    } else {
      *why = full + ": unknown key (unit, calibration, min, max, slew_per_s)";
      return false;
    }
  }
  return true;
}

}  // namespace mrd::profile
