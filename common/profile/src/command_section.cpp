#include "command_section.hpp"

#include <cmath>
#include <sstream>

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

std::string ShowNumber(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

std::string CheckCommandCarrier(const CommandMap& map, const std::string& unit,
                                const SetpointCarrier& carrier, const char** key) {
  // Half a raw step (rounding to the wire) and a relative margin for floats.
  const auto tol = [&](double v) { return carrier.step / 2 + 1e-9 * (1.0 + std::fabs(v)); };
  const auto inside = [&](double v) {
    return v >= carrier.lo - tol(carrier.lo) && v <= carrier.hi + tol(carrier.hi);
  };
  // Built with a stream: GCC 12 sees a false -Wrestrict in long string concatenations.
  std::ostringstream why;
  why.precision(6);
  const auto range = [&]() -> std::ostream& {
    return why << "[" << carrier.lo << ", " << carrier.hi << "] " << unit;
  };
  *key = nullptr;
  if (map.has_range()) {
    for (const bool is_max : {true, false}) {
      const double v = is_max ? map.max() : map.min();
      if (inside(v)) continue;
      *key = is_max ? "max" : "min";
      why << "command." << *key << " " << v << " " << unit << " is beyond what " << carrier.name
          << " can carry (";
      range() << "): set-points there would be refused on the wire and replaced by the safe "
                 "state (no current when the most is asked); give the driver's range within it";
      return why.str();
    }
  } else if (map.points() >= 2) {
    double lo = 0.0, hi = 0.0;
    map.Reach(1e300, &lo, &hi);
    if (!inside(lo) || !inside(hi)) {
      why << "command.calibration reaches " << (inside(lo) ? hi : lo) << " " << unit
          << ", beyond what " << carrier.name << " can carry (";
      range() << "); give [command] min and max within it";
      return why.str();
    }
  }
  const double safe = map.SafeSetpoint(0.0), off = map.Off();
  if (!inside(safe)) {
    why << "the safe state (E = 0 V) gives " << safe << " " << unit << ", beyond what "
        << carrier.name << " can carry (";
    range() << ")";
    return why.str();
  }
  if (std::fabs(safe - off) > tol(off)) {
    why << "the safe state (E = 0 V; also the shutdown's last command) gives " << safe << " "
        << unit << " on " << carrier.name << ", not the driver's off (" << off << " " << unit
        << "): "
        << (map.decreasing() ? "the calibration falls as E rises, so 0 V is its most current"
                             : "the calibration does not give the off value at 0 V")
        << "; a driver without an enable would be driven in every safe period";
    return why.str();
  }
  return "";
}

bool CheckCommandCarrierAt(const ProfileContext& c, const toml::table& root, const CommandMap& map,
                           const std::string& unit, const SetpointCarrier& carrier,
                           const char* output_path) {
  const char* key = nullptr;
  const std::string why = CheckCommandCarrier(map, unit, carrier, &key);
  if (why.empty()) return true;
  const toml::node* at = root.get("command");
  if (at != nullptr && key != nullptr && at->is_table() && at->as_table()->get(key) != nullptr) {
    at = at->as_table()->get(key);
  }
  return c.Fail(at != nullptr ? at : root.at_path(output_path).node(), why);
}

bool ReadCommand(const ProfileContext& c, const toml::table& t, const std::string& dir,
                 std::string* unit, CommandMap* map) {
  CommandSection cmd{*unit, -1e300, 1e300, 0.0};
  const toml::node* bad = nullptr;
  std::string reason;
  if (!ReadCommandSection(t, dir, &cmd, map, &bad, &reason)) return c.Fail(bad, reason);
  *unit = cmd.unit;
  std::string why;
  if (!map->SetRange(cmd.min, cmd.max, cmd.slew_per_s, &why)) return c.Fail(&t, why);
  return true;
}

}  // namespace mrd::profile
