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

std::function<bool(const toml::node&, std::string*)> Text(std::string* out) {
  return [=](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<std::string>();
    if (!v) return *why = "must be a string", false;
    if (v->empty()) return *why = "must not be empty", false;
    *out = *v;
    return true;
  };
}

std::function<bool(const toml::node&, std::string*)> Flag(bool* out) {
  return [=](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<bool>();
    if (!v) return *why = "must be true or false", false;
    *out = *v;
    return true;
  };
}

// Duration given in a unit (1e3 for us, 1e6 for ms) into ns.
std::function<bool(const toml::node&, std::string*)> Duration(std::int64_t* out_ns, double unit_ns,
                                                             double lo, double hi) {
  return [=](const toml::node& n, std::string* why) {
    double v = 0.0;
    if (!Number(&v, lo, hi)(n, why)) return false;
    *out_ns = static_cast<std::int64_t>(std::llround(v * unit_ns));
    return true;
  };
}

// A list of names, each one of `allowed` (bit i = allowed[i]), no repeats, into a bit mask.
std::function<bool(const toml::node&, std::string*)> Names(std::uint32_t* mask,
                                                          std::vector<std::string> allowed) {
  return [=](const toml::node& n, std::string* why) {
    const toml::array* a = n.as_array();
    std::string names;
    for (const auto& name : allowed) {
      if (!name.empty()) names += (names.empty() ? "" : ", ") + name;
    }
    if (a == nullptr) return *why = "must be a list of names from: " + names, false;
    std::uint32_t m = 0;
    for (const toml::node& e : *a) {
      const auto v = e.value_exact<std::string>();
      const auto it = v && !v->empty() ? std::find(allowed.begin(), allowed.end(), *v)
                                       : allowed.end();
      if (it == allowed.end()) {
        return *why = "has '" + (v ? *v : std::string("?")) + "'; allowed: " + names, false;
      }
      const std::uint32_t bit = 1U << static_cast<unsigned>(it - allowed.begin());
      if ((m & bit) != 0) return *why = "names '" + *v + "' twice", false;
      m |= bit;
    }
    *mask = m;
    return true;
  };
}

std::vector<std::string> InputNames(std::initializer_list<Input> inputs) {
  std::vector<std::string> all(kNumInputs, "");
  for (Input i : inputs) all[static_cast<std::size_t>(i)] = InputName(i);
  return all;
}

std::vector<std::string> OutputNames(std::initializer_list<Output> outputs) {
  std::vector<std::string> all(kNumOutputs, "");
  for (Output o : outputs) all[static_cast<std::size_t>(o)] = OutputName(o);
  return all;
}

// Line of [section] key (or of the section when the key is absent).
std::string Where(const toml::table& root, const std::string& source, const char* section,
                  const char* key) {
  const toml::node* sec = root.get(section);
  const toml::node* n = sec != nullptr && sec->is_table() ? sec->as_table()->get(key) : nullptr;
  const toml::node* at = n != nullptr ? n : sec;
  const auto line = at != nullptr ? at->source().begin.line : 0U;
  return source + ":" + std::to_string(line) + ": ";
}

// Routing and connection checks across the bus sections (io_config.hpp).
bool CheckIo(const toml::table& root, const std::string& source, const FirmwareConfig& c,
             std::string* error) {
  const IoConfig& io = c.io;
  if (!io.any()) return true;
  struct Bus {
    const char* name;
    bool enabled;
    std::uint32_t inputs, outputs;
  };
  const Bus buses[] = {{"can", io.can.enabled, io.can.inputs, io.can.outputs},
                       {"modbus", io.modbus.enabled, io.modbus.inputs, io.modbus.outputs},
                       {"gpio", io.gpio.enabled, io.gpio.inputs, io.gpio.outputs}};
  std::uint32_t inputs = 0, outputs = 0;
  for (const Bus& b : buses) {
    if (!b.enabled) continue;
    if (b.inputs == 0 && b.outputs == 0) {
      *error = Where(root, source, b.name, "inputs") + "[" + b.name +
               "] serves no input and drives no output (give 'inputs' and/or 'outputs')";
      return false;
    }
    for (std::size_t i = 0; i < kNumInputs; ++i) {
      if ((b.inputs & inputs & (1U << i)) != 0) {
        *error = Where(root, source, b.name, "inputs") + "input '" +
                 InputName(static_cast<Input>(i)) + "' has two sources";
        return false;
      }
    }
    constexpr std::uint32_t kShared = Bit(Output::kHeartbeat) | Bit(Output::kStatus);
    for (std::size_t i = 0; i < kNumOutputs; ++i) {
      if ((b.outputs & outputs & ~kShared & (1U << i)) != 0) {
        *error = Where(root, source, b.name, "outputs") + "output '" +
                 OutputName(static_cast<Output>(i)) + "' is driven by two buses";
        return false;
      }
    }
    inputs |= b.inputs;
    outputs |= b.outputs;
  }
  const ControllerConfig& k = c.controller;
  auto need = [&](Input in, const char* why) {
    if ((inputs & Bit(in)) != 0) return true;
    *error = source + ": no bus serves input '" + InputName(in) + "' (" + why + ")";
    return false;
  };
  if (k.velocity_source == VelocitySource::kMeasured) {
    if (!need(Input::kVelocity, "[velocity] source = \"measured\"")) return false;
  } else if (!need(Input::kDisplacement, "[velocity] source = \"displacement\"")) {
    return false;
  }
  if (k.law.mode == ControlMode::kForceTracking && !need(Input::kDemand, "law \"force\"")) {
    return false;
  }
  if ((k.law.mode == ControlMode::kSkyhookOnOff || k.law.mode == ControlMode::kSkyhookContinuous) &&
      !need(Input::kBodyVelocity, "skyhook laws")) {
    return false;
  }
  if ((outputs & Bit(Output::kCommand)) == 0) {
    *error = source + ": no bus drives the 'command' output (the current driver's set-point)";
    return false;
  }
  if (io.can.enabled && io.can.interface.empty() == io.can.local_bus.empty()) {
    *error = Where(root, source, "can", "interface") +
             "[can] needs exactly one of 'interface' (SocketCAN) and 'local_bus' (socket path)";
    return false;
  }
  if (io.modbus.enabled && io.modbus.mode == ModbusMode::kRtu && io.modbus.device.empty()) {
    *error = Where(root, source, "modbus", "mode") + "[modbus] mode \"rtu\" needs 'device'";
    return false;
  }
  if (io.gpio.enabled) {
    const GpioConfig& g = io.gpio;
    if (g.chip.empty() == g.sim_chip.empty()) {
      *error = Where(root, source, "gpio", "chip") +
               "[gpio] needs exactly one of 'chip' (libgpiod) and 'sim_chip' (simulated chip)";
      return false;
    }
    struct Line {
      bool used;
      int offset;
      const char* key;
    };
    const Line lines[] = {
        {(g.outputs & Bit(Output::kEnable)) != 0, g.enable_line, "enable_line"},
        {(g.outputs & Bit(Output::kHeartbeat)) != 0, g.heartbeat_line, "heartbeat_line"},
        {(g.inputs & Bit(Input::kFaultLine)) != 0, g.fault_line, "fault_line"},
        {(g.inputs & Bit(Input::kDisplacement)) != 0, g.encoder_a_line, "encoder_a_line"},
        {(g.inputs & Bit(Input::kDisplacement)) != 0, g.encoder_b_line, "encoder_b_line"}};
    for (const Line& l : lines) {
      if (l.used && l.offset < 0) {
        *error = Where(root, source, "gpio", "inputs") + "[gpio] needs '" + l.key + "'";
        return false;
      }
      for (const Line& o : lines) {
        if (&o != &l && l.used && o.used && o.offset == l.offset) {
          *error = Where(root, source, "gpio", l.key) + "[gpio] '" + l.key + "' and '" + o.key +
                   "' are the same line " + std::to_string(l.offset);
          return false;
        }
      }
    }
  }
  return true;
}

bool Apply(const toml::table& root, const std::string& source, FirmwareConfig* c,
           std::string* error) {
  double period_us = static_cast<double>(c->period_ns) / 1e3;
  double max_age_ms = static_cast<double>(c->controller.watchdog.max_age_ns) / 1e6;
  double e_max = c->e_max.value_or(NAN);
  bool e_max_set = false;
  ControllerConfig& k = c->controller;
  SimulationConfig& s = c->simulation;
  IoConfig& io = c->io;
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
      {"can",
       {{"inputs", Names(&io.can.inputs, InputNames({Input::kVelocity, Input::kDisplacement,
                                                     Input::kDemand, Input::kBodyVelocity,
                                                     Input::kForce}))},
        {"outputs", Names(&io.can.outputs, OutputNames({Output::kCommand, Output::kEnable,
                                                        Output::kHeartbeat, Output::kStatus}))},
        {"interface", Text(&io.can.interface)},
        {"local_bus", Text(&io.can.local_bus)},
        {"tx_deadline_us", Duration(&io.can.tx_deadline_ns, 1e3, 1.0, 1e6)},
        {"status_period_ms", Duration(&io.can.status_period_ns, 1e6, 1.0, 1e4)},
        {"heartbeat_period_ms", Duration(&io.can.heartbeat_period_ns, 1e6, 1.0, 1e4)}}},
      {"modbus",
       {{"inputs", Names(&io.modbus.inputs, InputNames({Input::kVelocity, Input::kDisplacement,
                                                        Input::kDemand, Input::kBodyVelocity,
                                                        Input::kForce, Input::kFaultLine}))},
        {"outputs", Names(&io.modbus.outputs, OutputNames({Output::kCommand, Output::kEnable,
                                                           Output::kHeartbeat, Output::kStatus}))},
        {"mode", Choice(&io.modbus.mode, {{"tcp", ModbusMode::kTcp}, {"rtu", ModbusMode::kRtu}})},
        {"host", Text(&io.modbus.host)},
        {"port", Integer(&io.modbus.port, 1, 65535)},
        {"device", Text(&io.modbus.device)},
        {"baud", Integer(&io.modbus.baud, 50, 4'000'000)},
        {"parity", Choice(&io.modbus.parity, {{"N", 'N'}, {"E", 'E'}, {"O", 'O'}})},
        {"data_bits", Integer(&io.modbus.data_bits, 5, 8)},
        {"stop_bits", Integer(&io.modbus.stop_bits, 1, 2)},
        {"slave", Integer(&io.modbus.slave, 1, 247)},
        {"response_timeout_ms", Duration(&io.modbus.response_timeout_ns, 1e6, 0.1, 1e4)},
        {"retries", Integer(&io.modbus.retries, 0, 10)},
        {"poll_period_us", Duration(&io.modbus.poll_period_ns, 1e3, 100.0, 1e6)}}},
      {"gpio",
       {{"inputs", Names(&io.gpio.inputs, InputNames({Input::kDisplacement, Input::kFaultLine}))},
        {"outputs", Names(&io.gpio.outputs, OutputNames({Output::kEnable, Output::kHeartbeat}))},
        {"chip", Text(&io.gpio.chip)},
        {"sim_chip", Text(&io.gpio.sim_chip)},
        {"enable_line", Integer(&io.gpio.enable_line, 0, 1023)},
        {"heartbeat_line", Integer(&io.gpio.heartbeat_line, 0, 1023)},
        {"fault_line", Integer(&io.gpio.fault_line, 0, 1023)},
        {"encoder_a_line", Integer(&io.gpio.encoder_a_line, 0, 1023)},
        {"encoder_b_line", Integer(&io.gpio.encoder_b_line, 0, 1023)},
        {"fault_active_low", Flag(&io.gpio.fault_active_low)},
        {"counts_per_cm", Number(&io.gpio.counts_per_cm, 1e-3, 1e9)}}},
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
    if (name.str() == "can") io.can.enabled = true;
    if (name.str() == "modbus") io.modbus.enabled = true;
    if (name.str() == "gpio") io.gpio.enabled = true;
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
  if (!CheckIo(root, source, *c, error)) return false;
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
