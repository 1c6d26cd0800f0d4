// Compiled with exceptions and RTTI (toml++ needs them); every exception is caught here.
#include "mrd/firmware/config.hpp"

#include <toml++/toml.h>

#include <cmath>
#include <fstream>
#include <algorithm>
#include <functional>
#include <sstream>
#include <vector>

namespace mrd::firmware {
namespace {

using Setter = std::function<bool(const toml::node&, std::string*)>;  // false: *why

// One configuration key: the single source of parsing, defaults and the reference
// (ConfigReference, docs/firmware_config.md).
struct Key {
  const char* name;
  Setter set;
  std::function<std::string()> show;  // current value as TOML ("" when unset)
  std::string accepts;                // accepted values in words
  const char* unit;                   // "" when none
  const char* description;
};

std::string Show(double v) {
  std::ostringstream s;
  s << v;
  std::string t = s.str();
  if (t.find_first_not_of("-0123456789") == std::string::npos) t += ".0";  // stays a TOML float
  return t;
}

std::string Range(double lo, double hi) { return "[" + Show(lo) + ", " + Show(hi) + "]"; }

Key Number(const char* name, double* out, double lo, double hi, const char* unit,
           const char* description) {
  Setter set = [=](const toml::node& n, std::string* why) {
    const auto v = n.value<double>();
    if (!v) return *why = "must be a number", false;
    if (!std::isfinite(*v) || *v < lo || *v > hi) return *why = "must be in " + Range(lo, hi), false;
    *out = *v;
    return true;
  };
  return {name, set, [out] { return Show(*out); }, Range(lo, hi), unit, description};
}

template <typename Int>
Key Integer(const char* name, Int* out, std::int64_t lo, std::int64_t hi, const char* unit,
            const char* description) {
  const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  Setter set = [=](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<std::int64_t>();
    if (!v) return *why = "must be an integer", false;
    if (*v < lo || *v > hi) return *why = "must be in " + range, false;
    *out = static_cast<Int>(*v);
    return true;
  };
  return {name, set, [out] { return std::to_string(*out); }, range + " (integer)", unit,
          description};
}

template <typename E>
Key Choice(const char* name, E* out, std::vector<std::pair<std::string, E>> choices,
           const char* description) {
  std::string names;
  for (const auto& c : choices) names += (names.empty() ? "" : " | ") + c.first;
  Setter set = [=](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<std::string>();
    for (const auto& [cname, value] : choices) {
      if (v && *v == cname) {
        *out = value;
        return true;
      }
    }
    return *why = "must be one of " + names, false;
  };
  auto show = [out, choices] {
    for (const auto& [cname, value] : choices) {
      if (*out == value) return "\"" + cname + "\"";
    }
    return std::string();
  };
  return {name, set, show, names, "", description};
}

Key Bool(const char* name, bool* out, const char* description) {
  Setter set = [out](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<bool>();
    if (!v) return *why = "must be true or false", false;
    *out = *v;
    return true;
  };
  return {name, set, [out] { return std::string(*out ? "true" : "false"); }, "true | false", "",
          description};
}

// Values kept in other units than the config's while the table is in use.
struct Scratch {
  double period_us;
  double max_age_ms;
  double e_max;
  bool e_max_set = false;
};

using Sections = std::vector<std::pair<std::string, std::vector<Key>>>;

// The key table, bound to c and scratch (which must outlive it).
Sections KeyTable(FirmwareConfig* c, Scratch* x) {
  ControllerConfig& k = c->controller;
  SimulationConfig& s = c->simulation;
  Key e_max = Number("e_max", &x->e_max, 0.0, 1e3, "V",
                     "Highest command; must lie in the table's range. Default: the table's "
                     "E_max.");
  e_max.set = [x, inner = e_max.set](const toml::node& n, std::string* why) {
    x->e_max_set = true;
    return inner(n, why);
  };
  e_max.show = [] { return std::string(); };
  return {
      {"loop",
       {Number("period_us", &x->period_us, 100.0, 1e6, "us", "Control period."),
        Integer("priority", &c->priority, 0, 99, "",
                "SCHED_FIFO priority of the loop thread; 0 = do not ask for real time."),
        Bool("lock_memory", &c->lock_memory, "Lock all memory (mlockall) before the loop.")}},
      {"control",
       {Choice("law", &k.law.mode,
               {{"force", ControlMode::kForceTracking},
                {"constant", ControlMode::kConstantVoltage},
                {"skyhook-on-off", ControlMode::kSkyhookOnOff},
                {"skyhook", ControlMode::kSkyhookContinuous}},
               "Control law: track a force demand through the inverted model, a constant "
               "voltage, or skyhook (on-off or continuous)."),
        e_max,
        Number("constant_voltage", &k.law.constant_voltage, -1e3, 1e3, "V",
               "Command of law = \"constant\" (passive-off 0, passive-on E_max)."),
        Number("skyhook_gain", &k.law.skyhook_gain, 0.0, 1e6, "N s/cm",
               "Gain of law = \"skyhook\"."),
        Number("force_limit", &k.law.force_limit, 1e-9, 1e9, "N",
               "Limit of the force demand's magnitude.")}},
      {"velocity",
       {Choice("source", &k.velocity_source,
               {{"measured", VelocitySource::kMeasured},
                {"displacement", VelocitySource::kDisplacement}},
               "Velocity from the sensor, or differentiated from the displacement through a "
               "low-pass."),
        Number("cutoff_hz", &k.cutoff_hz, 1e-3, 1e5, "Hz",
               "Cut-off of the displacement differentiator.")}},
      {"safety",
       {Number("safe_voltage", &k.safe_voltage, -1e3, 1e3, "V",
               "Command in the safe state; must lie in the table's range."),
        Number("max_age_ms", &x->max_age_ms, 1e-3, 1e4, "ms",
               "Sensor data older than this is stale (safe state)."),
        Integer("recover_periods", &k.watchdog.recover_periods, 1, 1'000'000, "",
                "Clean periods before leaving the safe state."),
        Number("velocity_limit", &k.velocity_limit, 0.0, 1e6, "cm/s",
               "|v| above this is implausible (safe state); 0 = no limit."),
        Number("displacement_limit", &k.displacement_limit, 0.0, 1e6, "cm",
               "|x| above this is implausible (safe state); 0 = no limit.")}},
      {"simulation",
       {Number("amplitude_cm", &s.amplitude_cm, 0.0, 100.0, "cm",
               "Dry-run plant: displacement amplitude."),
        Number("frequency_hz", &s.frequency_hz, 0.0, 1e3, "Hz",
               "Dry-run plant: displacement frequency."),
        Number("demand_amplitude_n", &s.demand_amplitude_n, 0.0, 1e6, "N",
               "Dry-run plant: amplitude of the force demand."),
        Number("demand_frequency_hz", &s.demand_frequency_hz, 0.0, 1e3, "Hz",
               "Dry-run plant: frequency of the force demand."),
        Number("body_amplitude", &s.body_amplitude, 0.0, 1e3, "cm/s",
               "Dry-run plant: amplitude of the body velocity (skyhook laws)."),
        Number("body_frequency_hz", &s.body_frequency_hz, 0.0, 1e3, "Hz",
               "Dry-run plant: frequency of the body velocity."),
        Number("body_phase_rad", &s.body_phase_rad, -10.0, 10.0, "rad",
               "Dry-run plant: phase of the body velocity."),
        Integer("substeps", &s.substeps, 1, 10000, "",
                "Dry-run plant: RK4 steps per period.")}},
  };
}

bool Apply(const toml::table& root, const std::string& source, FirmwareConfig* c,
           std::string* error) {
  Scratch x{static_cast<double>(c->period_ns) / 1e3,
            static_cast<double>(c->controller.watchdog.max_age_ns) / 1e6,
            c->e_max.value_or(NAN)};
  ControllerConfig& k = c->controller;
  const Sections sections = KeyTable(c, &x);
  auto fail = [&](const toml::node& n, const std::string& what) {
    *error = source + ":" + std::to_string(n.source().begin.line) + ": " + what;
    return false;
  };
  for (const auto& [name, node] : root) {
    const auto section = std::find_if(sections.begin(), sections.end(), [&](const auto& sec) {
      return sec.first == name.str();
    });
    if (section == sections.end()) return fail(node, "unknown section '" + std::string(name.str()) + "'");
    const toml::table* tbl = node.as_table();
    if (tbl == nullptr) return fail(node, "'" + std::string(name.str()) + "' must be a table");
    for (const auto& [key, value] : *tbl) {
      const auto entry = std::find_if(section->second.begin(), section->second.end(),
                                       [&](const Key& e) { return key.str() == e.name; });
      if (entry == section->second.end()) {
        return fail(value, "unknown key '" + std::string(key.str()) + "' in [" + section->first + "]");
      }
      std::string why;
      if (!entry->set(value, &why)) {
        return fail(value, "'" + std::string(key.str()) + "' " + why);
      }
    }
  }
  c->period_ns = static_cast<std::int64_t>(std::llround(x.period_us * 1e3));
  k.watchdog.max_age_ns = static_cast<std::int64_t>(std::llround(x.max_age_ms * 1e6));
  if (x.e_max_set) c->e_max = x.e_max;
  return true;
}

}  // namespace

std::string ConfigReference() {
  try {
    FirmwareConfig c;
    Scratch x{static_cast<double>(c.period_ns) / 1e3,
              static_cast<double>(c.controller.watchdog.max_age_ns) / 1e6, 2.25};
    std::string out =
        "# mrd-firmware configuration reference\n\n"
        "Generated by `mrd-firmware --print-config-reference` from the key table in\n"
        "`firmware/src/config.cpp` (a test checks that this file equals its output).\n\n"
        "`mrd-firmware --config FILE.toml` reads TOML once at start-up. Every key is optional;\n"
        "an unknown section or key, a wrong type or a value out of range is an error\n"
        "(`error: FILE:LINE: reason`, exit 2).\n";
    for (const auto& [section, keys] : KeyTable(&c, &x)) {
      out += "\n## [" + section + "]\n\n";
      out += "| key | default | unit | accepts | meaning |\n|---|---|---|---|---|\n";
      for (const Key& key : keys) {
        const std::string def = key.show();
        std::string accepts;  // '|' would end the Markdown cell
        for (const char ch : key.accepts) accepts += ch == '|' ? std::string("or") : std::string(1, ch);
        out += std::string("| `") + key.name + "` | " + (def.empty() ? "table's" : "`" + def + "`") +
               " | " + key.unit + " | " + accepts + " | " + key.description + " |\n";
      }
    }
    return out;
  } catch (const std::exception&) {
    return "";
  }
}

bool ParseConfig(std::string_view text, const std::string& source, FirmwareConfig* config,
                 std::string* error) {
  try {
    const toml::table root = toml::parse(text, source);
    FirmwareConfig c = *config;
    if (!Apply(root, source, &c, error)) return false;
    *config = c;
    return true;
  } catch (const toml::parse_error& e) {
    *error = source + ":" + std::to_string(e.source().begin.line) + ": " +
             std::string(e.description());
    return false;
  } catch (const std::exception& e) {
    *error = source + ": " + e.what();
    return false;
  }
}

bool LoadConfigFile(const std::string& path, FirmwareConfig* config, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot open";
    return false;
  }
  std::stringstream text;
  text << in.rdbuf();
  return ParseConfig(text.str(), path, config, error);
}

}  // namespace mrd::firmware
