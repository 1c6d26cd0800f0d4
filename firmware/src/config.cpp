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

struct Key {
  const char* name;
  std::function<bool(const toml::node&, std::string*)> set;  // false: *why
};

std::function<bool(const toml::node&, std::string*)> Number(double* out, double lo, double hi) {
  return [=](const toml::node& n, std::string* why) {
    const auto v = n.value<double>();
    if (!v) return *why = "must be a number", false;
    if (!std::isfinite(*v) || *v < lo || *v > hi) {
      std::ostringstream s;
      s << "must be in [" << lo << ", " << hi << "]";
      return *why = s.str(), false;
    }
    *out = *v;
    return true;
  };
}

template <typename Int>
std::function<bool(const toml::node&, std::string*)> Integer(Int* out, std::int64_t lo,
                                                            std::int64_t hi) {
  return [=](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<std::int64_t>();
    if (!v) return *why = "must be an integer", false;
    if (*v < lo || *v > hi) {
      return *why = "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", false;
    }
    *out = static_cast<Int>(*v);
    return true;
  };
}

template <typename E>
std::function<bool(const toml::node&, std::string*)> Choice(
    E* out, std::vector<std::pair<std::string, E>> choices) {
  return [=](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<std::string>();
    std::string names;
    for (const auto& [name, value] : choices) {
      if (v && *v == name) {
        *out = value;
        return true;
      }
      names += (names.empty() ? "" : " | ") + name;
    }
    return *why = "must be one of " + names, false;
  };
}

bool Apply(const toml::table& root, const std::string& source, FirmwareConfig* c,
           std::string* error) {
  double period_us = static_cast<double>(c->period_ns) / 1e3;
  double max_age_ms = static_cast<double>(c->controller.watchdog.max_age_ns) / 1e6;
  double e_max = c->e_max.value_or(NAN);
  bool e_max_set = false;
  ControllerConfig& k = c->controller;
  SimulationConfig& s = c->simulation;
  const std::vector<std::pair<std::string, std::vector<Key>>> sections = {
      {"loop",
       {{"period_us", Number(&period_us, 100.0, 1e6)},
        {"priority", Integer(&c->priority, 0, 99)},
        {"lock_memory", [c](const toml::node& n, std::string* why) {
           const auto v = n.value_exact<bool>();
           if (!v) return *why = "must be true or false", false;
           c->lock_memory = *v;
           return true;
         }}}},
      {"control",
       {{"law", Choice(&k.law.mode, {{"force", ControlMode::kForceTracking},
                                     {"constant", ControlMode::kConstantVoltage},
                                     {"skyhook-on-off", ControlMode::kSkyhookOnOff},
                                     {"skyhook", ControlMode::kSkyhookContinuous}})},
        {"e_max", [&](const toml::node& n, std::string* why) {
           e_max_set = true;
           return Number(&e_max, 0.0, 1e3)(n, why);
         }},
        {"constant_voltage", Number(&k.law.constant_voltage, -1e3, 1e3)},
        {"skyhook_gain", Number(&k.law.skyhook_gain, 0.0, 1e6)},
        {"force_limit", Number(&k.law.force_limit, 1e-9, 1e9)}}},
      {"velocity",
       {{"source", Choice(&k.velocity_source, {{"measured", VelocitySource::kMeasured},
                                               {"displacement", VelocitySource::kDisplacement}})},
        {"cutoff_hz", Number(&k.cutoff_hz, 1e-3, 1e5)}}},
      {"safety",
       {{"safe_voltage", Number(&k.safe_voltage, -1e3, 1e3)},
        {"max_age_ms", Number(&max_age_ms, 1e-3, 1e4)},
        {"recover_periods", Integer(&k.watchdog.recover_periods, 1, 1'000'000)},
        {"velocity_limit", Number(&k.velocity_limit, 0.0, 1e6)},
        {"displacement_limit", Number(&k.displacement_limit, 0.0, 1e6)}}},
      {"simulation",
       {{"amplitude_cm", Number(&s.amplitude_cm, 0.0, 100.0)},
        {"frequency_hz", Number(&s.frequency_hz, 0.0, 1e3)},
        {"demand_amplitude_n", Number(&s.demand_amplitude_n, 0.0, 1e6)},
        {"demand_frequency_hz", Number(&s.demand_frequency_hz, 0.0, 1e3)},
        {"body_amplitude", Number(&s.body_amplitude, 0.0, 1e3)},
        {"body_frequency_hz", Number(&s.body_frequency_hz, 0.0, 1e3)},
        {"body_phase_rad", Number(&s.body_phase_rad, -10.0, 10.0)},
        {"substeps", Integer(&s.substeps, 1, 10000)}}},
  };
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
  c->period_ns = static_cast<std::int64_t>(std::llround(period_us * 1e3));
  k.watchdog.max_age_ns = static_cast<std::int64_t>(std::llround(max_age_ms * 1e6));
  if (e_max_set) c->e_max = e_max;
  return true;
}

}  // namespace

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
