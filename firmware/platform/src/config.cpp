// Compiled with exceptions and RTTI (toml++ needs them); every exception is caught here.
#include "mrd/firmware/config.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <sstream>
#include <vector>

#include "mrd/common/file_path.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/clipped_optimal_file.hpp"
#include "mrd/firmware/io/input_roles.hpp"
#include "mrd/firmware/period_log.hpp"
#include "mrd/firmware/safe_state.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/profile/pwm_profile.hpp"

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
  const char* type = "";                // "float", "integer", "bool", "choice", "string", "list"
  Tunable tunable = Tunable::kRestart;  // when a change takes effect (params.hpp)
};

// The key, marked as changeable while the loop runs (mrd-firmware ctl set, SIGHUP).
Key Runtime(Key key) {
  key.tunable = Tunable::kRuntime;
  return key;
}

// The key, marked as changeable by a reload (SIGHUP; a fresh controller).
Key Reload(Key key) {
  key.tunable = Tunable::kReload;
  return key;
}

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
    if (!std::isfinite(*v) || *v < lo || *v > hi)
      return *why = "must be in " + Range(lo, hi), false;
    *out = *v;
    return true;
  };
  return {name, set, [out] { return Show(*out); }, Range(lo, hi), unit, description, "float"};
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
  return {name,        set,      [out] { return std::to_string(*out); }, range + " (integer)", unit,
          description, "integer"};
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
  return {name, set, show, names, "", description, "choice"};
}

Key Bool(const char* name, bool* out, const char* description) {
  Setter set = [out](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<bool>();
    if (!v) return *why = "must be true or false", false;
    *out = *v;
    return true;
  };
  return {name,           set, [out] { return std::string(*out ? "true" : "false"); },
          "true | false", "",  description,
          "bool"};
}

// A string the firmware hands to the system (an interface, host or path): 1 ... max_len bytes,
// no control characters (an embedded NUL would silently cut it at the system call), and none
// of `banned` (e.g. "/: " for an interface name).
Key Text(const char* name, std::string* out, std::size_t max_len, const char* limit_why,
         const char* banned, const char* description) {
  std::string accepts = "a string of 1 to " + std::to_string(max_len) + " bytes (" + limit_why +
                        "), no control characters";
  for (const char* b = banned; *b != '\0'; ++b) {
    accepts += std::string(b[1] == '\0' ? " or " : ", ") +
               (*b == ' ' ? std::string("blanks") : "'" + std::string(1, *b) + "'");
  }
  Setter set = [=](const toml::node& n, std::string* why) {
    const auto v = n.value_exact<std::string>();
    if (!v) return *why = "must be a string", false;
    if (v->empty()) return *why = "must not be empty", false;
    for (const char ch : *v) {
      const auto c = static_cast<unsigned char>(ch);
      if (c < 0x20 || c == 0x7f) {
        char hex[5];
        std::snprintf(hex, sizeof hex, "\\x%02x", c);
        return *why = std::string("must not contain control characters (has ") + hex + ")", false;
      }
      if (std::strchr(banned, ch) != nullptr) {
        return *why = std::string("must not contain ") +
                      (ch == ' ' ? std::string("blanks") : "'" + std::string(1, ch) + "'"),
               false;
      }
    }
    if (v->size() > max_len) {
      return *why = "is " + std::to_string(v->size()) + " bytes long; at most " +
                    std::to_string(max_len) + " (" + limit_why + ")",
             false;
    }
    *out = *v;
    return true;
  };
  return {name,    set, [out] { return out->empty() ? std::string("(none)") : "\"" + *out + "\""; },
          accepts, "",  description,
          "string"};
}

// A duration given in a unit of unit_ns nanoseconds (1e3: us, 1e6: ms), kept in ns.
Key Duration(const char* name, std::int64_t* out_ns, double unit_ns, double lo, double hi,
             const char* unit, const char* description) {
  Setter set = [=](const toml::node& n, std::string* why) {
    const auto v = n.value<double>();
    if (!v) return *why = "must be a number", false;
    if (!std::isfinite(*v) || *v < lo || *v > hi)
      return *why = "must be in " + Range(lo, hi), false;
    *out_ns = static_cast<std::int64_t>(std::llround(*v * unit_ns));
    return true;
  };
  return {name,          set,  [=] { return Show(static_cast<double>(*out_ns) / unit_ns); },
          Range(lo, hi), unit, description,
          "float"};
}

// A GPIO line offset; -1 (the default) is "not wired".
Key Line(const char* name, int* out, const char* description) {
  Key key = Integer(name, out, 0, 1023, "", description);
  key.show = [out] { return *out < 0 ? std::string("(not wired)") : std::to_string(*out); };
  return key;
}

// A list of names, each one of `allowed` (bit i = allowed[i]; "" = not allowed here), no
// repeats, into a bit mask.
Key Names(const char* name, std::uint32_t* mask, std::vector<std::string> allowed,
          const char* description) {
  std::string names;
  for (const auto& a : allowed) {
    if (!a.empty()) names += (names.empty() ? "" : ", ") + a;
  }
  Setter set = [=](const toml::node& n, std::string* why) {
    const toml::array* a = n.as_array();
    if (a == nullptr) return *why = "must be a list of names from: " + names, false;
    std::uint32_t m = 0;
    for (const toml::node& e : *a) {
      const auto v = e.value_exact<std::string>();
      const auto it =
          v && !v->empty() ? std::find(allowed.begin(), allowed.end(), *v) : allowed.end();
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
  auto show = [=] {
    std::string list;
    for (std::size_t i = 0; i < allowed.size(); ++i) {
      if ((*mask & (1U << i)) != 0) list += (list.empty() ? "\"" : ", \"") + allowed[i] + "\"";
    }
    return "[" + list + "]";
  };
  return {name, set, show, "a list of: " + names, "", description, "list"};
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

// Longest strings the system takes [bytes, without the NUL]: a network interface name
// (IFNAMSIZ 16), a UNIX socket path (sun_path 108), a DNS name, a path (PATH_MAX 4096).
constexpr std::size_t kMaxInterface = 15;
constexpr std::size_t kMaxSocketPath = 107;
constexpr std::size_t kMaxHost = 253;
constexpr std::size_t kMaxPath = 4095;

// [ctl] socket: a path; shown as its default when unset (the default depends on the
// environment, so the reference names the rule).
Key CtlSocket(std::string* out) {
  Key key = Text("socket", out, kMaxSocketPath, "a UNIX socket path", "",
                 "Path of the control socket (owner-only, mode 0600); setting it serves the "
                 "socket. A stale socket file is replaced; one a live firmware serves is "
                 "refused. Overridden by --ctl-socket.");
  key.show = [out] {
    return out->empty() ? std::string(
                              "($XDG_RUNTIME_DIR/mrd-firmware.sock, else "
                              "/run/mrd-firmware/ctl.sock)")
                        : "\"" + *out + "\"";
  };
  return key;
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
  IoConfig& io = c->io;
  LogConfig& lg = c->log;
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
        Bool("lock_memory", &c->lock_memory, "Lock all memory (mlockall) before the loop."),
        Choice("clock", &c->clock,
               {{"monotonic", LoopClock::kMonotonic}, {"grant", LoopClock::kGrant}},
               "Bus mode: the loop's time from CLOCK_MONOTONIC, or lockstep with the HIL "
               "harness: time grants on the [can] bus (docs/can_bus.md), else on the [modbus] "
               "grant register (docs/modbus_registers.md)."),
        Duration("grant_timeout_ms", &c->grant_timeout_ns, 1e6, 100.0, 3.6e6, "ms",
                 "clock = \"grant\": the loop waits for each grant however late it comes "
                 "(simulated time never depends on wall time); when none has come for this "
                 "wall time the harness is taken for gone and the firmware stops in the safe "
                 "state (exit 1, clock.missed_grants 1).")}},
      {"control",
       {Runtime(
            Choice("law", &k.law.mode,
                   {{"force", ControlMode::kForceTracking},
                    {"constant", ControlMode::kConstantVoltage},
                    {"skyhook-on-off", ControlMode::kSkyhookOnOff},
                    {"skyhook", ControlMode::kSkyhookContinuous},
                    {"open-loop", ControlMode::kOpenLoop},
                    {"groundhook", ControlMode::kGroundhook},
                    {"groundhook-on-off", ControlMode::kGroundhookOnOff},
                    {"hybrid", ControlMode::kHybrid},
                    {"add", ControlMode::kAdd},
                    {"sh-add", ControlMode::kSkyhookAdd},
                    {"clipped-optimal", ControlMode::kClippedOptimal}},
                   "Control law: track a force demand through the inverted model, a constant "
                   "voltage, skyhook (on-off or continuous), open-loop (the demand input is a "
                   "voltage command in mV, clamped to [E_min, E_max]: the harness's replay), "
                   "groundhook (continuous or on-off), hybrid skyhook-groundhook, add "
                   "(acceleration-driven damper), sh-add (mixed skyhook-ADD) or clipped-optimal "
                   "(Dyke et al. 1996, on three floor accelerations and the measured force; "
                   "[clipped_optimal]); docs/control_laws.md.")),
        Runtime(e_max),
        Runtime(Number("constant_voltage", &k.law.constant_voltage, -1e3, 1e3, "V",
                       "Command of law = \"constant\" (passive-off 0, passive-on E_max).")),
        Runtime(Number("skyhook_gain", &k.law.skyhook_gain, 0.0, 1e6, "N s/cm",
                       "Gain of law = \"skyhook\".")),
        Runtime(Number("groundhook_gain", &k.law.groundhook_gain, 0.0, 1e6, "N s/cm",
                       "Gain of law = \"groundhook\" (force per wheel velocity).")),
        Runtime(Number("hybrid_gain", &k.law.hybrid_gain, 0.0, 1e6, "N s/cm",
                       "Gain of law = \"hybrid\".")),
        Runtime(Number("hybrid_alpha", &k.law.hybrid_alpha, 0.0, 1.0, "",
                       "Blend of law = \"hybrid\": 1 skyhook only, 0 groundhook only.")),
        Runtime(Number("sh_add_alpha", &k.law.sh_add_alpha, 1e-3, 1e4, "rad/s",
                       "Crossover of law = \"sh-add\": the skyhook rule while the body "
                       "acceleration's magnitude is at most alpha times the body velocity's, "
                       "the ADD rule above (default 2 pi 1.5 Hz).")),
        Runtime(Number("force_limit", &k.law.force_limit, 1e-9, 1e9, "N",
                       "Limit of the force demand's magnitude."))}},
      {"clipped_optimal",
       {Reload(Text("gains", &c->clipped_gains_path, kMaxPath, "PATH_MAX", "",
                    "Gains of law = \"clipped-optimal\": the TOML file `mrd-structure design "
                    "--out` writes ([control.clipped_optimal]: ad, bd, cy, dy, l, k, v_max, "
                    "v_min), relative to this file; read and checked at start-up and on a "
                    "reload. The law needs it.")),
        Runtime(
            Choice("command", &k.law.clipped_command,
                   {{"clipped", ClippedCommand::kClipped}, {"inverse", ClippedCommand::kInverse}},
                   "What law = \"clipped-optimal\" commands: the clipped rule's voltage "
                   "(the gains' v_max when the damper force must grow towards the desired "
                   "force, else v_min; clamped to [E_min, E_max]), or the model's inverse "
                   "at the desired force (limited to force_limit)."))}},
      {"velocity",
       {Reload(Choice("source", &k.velocity_source,
                      {{"measured", VelocitySource::kMeasured},
                       {"displacement", VelocitySource::kDisplacement}},
                      "Velocity from the sensor, or differentiated from the displacement "
                      "through a low-pass.")),
        Runtime(Number("cutoff_hz", &k.cutoff_hz, 1e-3, 1e5, "Hz",
                       "Cut-off of the displacement differentiator."))}},
      {"safety",
       {Number("safe_voltage", &k.safe_voltage, -1e3, 1e3, "V",
               "Command in the safe state; must lie in the table's range."),
        Number("max_age_ms", &x->max_age_ms, 1e-3, 1e4, "ms",
               "Sensor data older than this is stale (safe state)."),
        Runtime(Integer("recover_periods", &k.watchdog.recover_periods, 1, 1'000'000, "",
                        "Clean periods before leaving the safe state.")),
        Runtime(Number("velocity_limit", &k.velocity_limit, 0.0, 1e6, "cm/s",
                       "|v| above this is implausible (safe state); 0 = no limit.")),
        Runtime(Number("displacement_limit", &k.displacement_limit, 0.0, 1e6, "cm",
                       "|x| above this is implausible (safe state), whenever a displacement is "
                       "measured, whether the model and the velocity use it or not; 0 = no "
                       "limit. With bus sections, a limit needs a bus serving input "
                       "'displacement' (the dry run's simulated damper always measures it)."))}},
      {"envelope",
       {Runtime(Bool("hold", &k.envelope,
                     "Hold the model's v, x and fed-back force to the table's operating "
                     "envelope (table v2; counted as excursions); false = evaluate any input.")),
        Runtime(Number("margin", &k.envelope_margin, 0.0, 100.0, "",
                       "Envelope widened on each side by this fraction of its range."))}},
      {"ctl",
       {Bool("enable", &c->ctl_enable,
             "Serve the control socket (mrd-firmware ctl; docs/tuning.md) at 'socket'."),
        CtlSocket(&c->ctl_socket)}},
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
        Integer("substeps", &s.substeps, 1, 10000, "", "Dry-run plant: RK4 steps per period.")}},
      {"can",
       {Names(
            "inputs", &io.can.inputs,
            InputNames({Input::kVelocity, Input::kDisplacement, Input::kDemand,
                        Input::kBodyVelocity, Input::kForce, Input::kFaultLine,
                        Input::kBodyAcceleration, Input::kWheelVelocity, Input::kFloorAcceleration1,
                        Input::kFloorAcceleration2, Input::kFloorAcceleration3}),
            "Signals read from CAN: those the profile maps (the built-in mrd-native maps all but "
            "fault_line; docs/can_bus.md)."),
        Names("outputs", &io.can.outputs,
              OutputNames({Output::kCommand, Output::kEnable, Output::kHeartbeat, Output::kStatus}),
              "Signals sent on CAN."),
        Text("interface", &io.can.interface, kMaxInterface, "IFNAMSIZ",
             "/: ", "SocketCAN interface (e.g. \"can0\"); or local_bus."),
        Text("local_bus", &io.can.local_bus, kMaxSocketPath, "a UNIX socket path", "",
             "UNIX socket path of a local frame bus (mrd-canbus; machines without AF_CAN)."),
        Text("profile", &io.can.profile, kMaxPath, "PATH_MAX", "",
             "Device profile (docs/devices.md): the driver's DBC messages and signals for each "
             "input and output, relative to this file; default: the built-in mrd-native "
             "(docs/mrd.dbc)."),
        Duration("tx_deadline_us", &io.can.tx_deadline_ns, 1e3, 1.0, 1e6, "us",
                 "A frame not sent by then is dropped (counted)."),
        Duration("status_period_ms", &io.can.status_period_ns, 1e6, 1.0, 1e4, "ms",
                 "Period of the status messages: FirmwareStatus and the live telemetry "
                 "FirmwareTelemetry (model force, demand, command; docs/telemetry.md)."),
        Duration("heartbeat_period_ms", &io.can.heartbeat_period_ns, 1e6, 1.0, 1e4, "ms",
                 "Period of the heartbeat frame."),
        Duration("fault_reset_ms", &io.can.fault_reset_ns, 1e6, 100.0, 600000.0, "ms",
                 "The profile's fault_reset bit: at most one reset edge per this time "
                 "(docs/devices.md).")}},
      {"modbus",
       {Names(
            "inputs", &io.modbus.inputs,
            InputNames({Input::kVelocity, Input::kDisplacement, Input::kDemand,
                        Input::kBodyVelocity, Input::kForce, Input::kFaultLine,
                        Input::kBodyAcceleration, Input::kWheelVelocity, Input::kFloorAcceleration1,
                        Input::kFloorAcceleration2, Input::kFloorAcceleration3}),
            "Signals read over Modbus: the built-in map (docs/modbus_registers.md) carries "
            "velocity, displacement, demand, body_velocity, force and fault_line; the others "
            "need a profile (docs/devices.md)."),
        Names("outputs", &io.modbus.outputs,
              OutputNames({Output::kCommand, Output::kEnable, Output::kHeartbeat, Output::kStatus}),
              "Signals written over Modbus."),
        Choice("mode", &io.modbus.mode, {{"tcp", ModbusMode::kTcp}, {"rtu", ModbusMode::kRtu}},
               "Modbus TCP or RTU (serial)."),
        Text("host", &io.modbus.host, kMaxHost, "a DNS name", " ", "TCP: the server's address."),
        Integer("port", &io.modbus.port, 1, 65535, "", "TCP: the server's port."),
        Text("device", &io.modbus.device, kMaxPath, "PATH_MAX", "",
             "RTU: the serial device (e.g. /dev/ttyS1)."),
        Integer("baud", &io.modbus.baud, 50, 4'000'000, "bit/s", "RTU: baud rate."),
        Choice("parity", &io.modbus.parity, {{"N", 'N'}, {"E", 'E'}, {"O", 'O'}}, "RTU: parity."),
        Integer("data_bits", &io.modbus.data_bits, 5, 8, "", "RTU: data bits."),
        Integer("stop_bits", &io.modbus.stop_bits, 1, 2, "", "RTU: stop bits."),
        Integer("slave", &io.modbus.slave, 1, 247, "", "Unit / slave id of the current driver."),
        Text("profile", &io.modbus.profile, kMaxPath, "PATH_MAX", "",
             "Modbus device profile (docs/devices.md): unit, table, address and type of each "
             "input and output, relative to this file; default: the built-in map "
             "(docs/modbus_registers.md, unit 'slave')."),
        Duration(
            "response_timeout_ms", &io.modbus.response_timeout_ns, 1e6, 0.1, 1e4, "ms",
            "A reply must be complete within it (RTU: plus the frames' time on the "
            "wire); also the TCP connect timeout. A stop takes at most twice it (RTU: plus that "
            "wire time)."),
        Integer("retries", &io.modbus.retries, 0, 10, "",
                "Extra attempts per transaction after a timeout or CRC error."),
        Duration("poll_period_us", &io.modbus.poll_period_ns, 1e3, 100.0, 1e6, "us",
                 "The I/O thread's read/write cycle.")}},
      {"gpio",
       {Names("inputs", &io.gpio.inputs, InputNames({Input::kDisplacement, Input::kFaultLine}),
              "Signals read from GPIO lines (displacement from a quadrature encoder)."),
        Names("outputs", &io.gpio.outputs, OutputNames({Output::kEnable, Output::kHeartbeat}),
              "Signals driven on GPIO lines."),
        Text("chip", &io.gpio.chip, kMaxPath, "PATH_MAX", "",
             "GPIO character device (libgpiod), e.g. \"gpiochip0\"."),
        Text("sim_chip", &io.gpio.sim_chip, kMaxPath, "PATH_MAX", "",
             "Path of a simulated chip (tests, mrd-hil)."),
        Line("enable_line", &io.gpio.enable_line, "Driver enable output (low in the safe state)."),
        Line("heartbeat_line", &io.gpio.heartbeat_line, "Heartbeat output (toggles per period)."),
        Line("fault_line", &io.gpio.fault_line, "Driver fault input."),
        Line("encoder_a_line", &io.gpio.encoder_a_line, "Quadrature encoder channel A."),
        Line("encoder_b_line", &io.gpio.encoder_b_line, "Quadrature encoder channel B."),
        Bool("fault_active_low", &io.gpio.fault_active_low, "The fault input is active low."),
        Number("counts_per_cm", &io.gpio.counts_per_cm, 1e-3, 1e9, "1/cm",
               "Quadrature counts (4 per line cycle) per cm of displacement.")}},
      {"pwm",
       {Names("outputs", &io.pwm.outputs, OutputNames({Output::kCommand}),
              "Signals driven as a PWM duty (the set-point; docs/devices.md)."),
        Text("sysfs", &io.pwm.sysfs, kMaxPath, "PATH_MAX", "",
             "The sysfs PWM class directory (a tree of the same ABI in tests and mrd-hil)."),
        Integer("chip", &io.pwm.chip, 0, 1023, "", "PWM chip: SYSFS/pwmchipN."),
        Integer("channel", &io.pwm.channel, 0, 1023, "",
                "PWM channel of the chip: pwmchipN/pwmM (exported when absent)."),
        Text("profile", &io.pwm.profile, kMaxPath, "PATH_MAX", "",
             "Device profile with the [pwm] section (period, polarity, duty range) and the "
             "[command] map, relative to this file; default: the [can] section's profile.")}},
      {"log",
       {Bool("enabled", &lg.enabled,
             "Write the per-period log (docs/logging.md) when a path is given (here or "
             "--log FILE); false = no log even with a path."),
        Text("path", &lg.path, kMaxPath, "PATH_MAX", "",
             "The log file, relative to this file; rotated files are PATH.1, PATH.2, ... "
             "(newest first). Default: none, no log (mrd-firmware --log FILE sets it)."),
        Integer("max_bytes", &lg.max_bytes, 65536, std::int64_t{1} << 32, "bytes",
                "Size limit of one file; the next block goes to a new file (rotation). At "
                "most 4 GiB: what `mrd log` reads."),
        Integer("files", &lg.files, 1, 1000, "",
                "Files kept, the current one included (1: the file restarts when full). A "
                "non-empty log from an earlier start becomes PATH.1 (files > 1)."),
        Integer("ring_records", &lg.ring_records, 16, 1 << 22, "",
                "Records the ring between the loop and the writer thread holds (rounded up "
                "to a power of two; preallocated and locked); a full ring drops records "
                "(counted)."),
        Integer("block_records", &lg.block_records, 1, 65536, "",
                "Records per block (each block has its CRC; a power cut loses at most the "
                "block being written)."),
        Duration("flush_ms", &lg.flush_ns, 1e6, 1.0, 60000.0, "ms",
                 "A partial block is written after this long (bounds what a crash loses)."),
        Bool("sync", &lg.sync,
             "fdatasync after every block (survives a power cut; more writes to flash).")}},
  };
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

// Each enabled bus serves or drives something, and no input has two sources, no output
// (but the shared heartbeat and status) two drivers. *inputs and *outputs: what the buses
// serve and drive together (Bit(Input), Bit(Output)).
bool CheckBusRouting(const toml::table& root, const std::string& source, const IoConfig& io,
                     std::uint32_t* inputs, std::uint32_t* outputs, std::string* error) {
  struct Bus {
    const char* name;
    bool enabled;
    std::uint32_t inputs, outputs;
  };
  const Bus buses[] = {{"can", io.can.enabled, io.can.inputs, io.can.outputs},
                       {"modbus", io.modbus.enabled, io.modbus.inputs, io.modbus.outputs},
                       {"gpio", io.gpio.enabled, io.gpio.inputs, io.gpio.outputs},
                       {"pwm", io.pwm.enabled, 0U, io.pwm.outputs}};
  for (const Bus& b : buses) {
    if (!b.enabled) continue;
    if (b.inputs == 0 && b.outputs == 0) {
      *error = Where(root, source, b.name, "inputs") + "[" + b.name +
               (b.name == std::string("pwm")
                    ? "] drives no output (give outputs = [\"command\"])"
                    : "] serves no input and drives no output (give 'inputs' and/or 'outputs')");
      return false;
    }
    for (std::size_t i = 0; i < kNumInputs; ++i) {
      if ((b.inputs & *inputs & (1U << i)) != 0) {
        *error = Where(root, source, b.name, "inputs") + "input '" +
                 InputName(static_cast<Input>(i)) + "' has two sources";
        return false;
      }
    }
    constexpr std::uint32_t kShared = Bit(Output::kHeartbeat) | Bit(Output::kStatus);
    for (std::size_t i = 0; i < kNumOutputs; ++i) {
      if ((b.outputs & *outputs & ~kShared & (1U << i)) != 0) {
        *error = Where(root, source, b.name, "outputs") + "output '" +
                 OutputName(static_cast<Output>(i)) + "' is driven by two buses";
        return false;
      }
    }
    *inputs |= b.inputs;
    *outputs |= b.outputs;
  }
  return true;
}

// The buses serve every input the velocity source and the control law read (inputs:
// Bit(Input) of the served ones).
bool CheckLawInputsServed(const std::string& source, const ControllerConfig& k,
                          std::uint32_t inputs, std::string* error) {
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
  if (k.law.mode == ControlMode::kOpenLoop && !need(Input::kDemand, "law \"open-loop\"")) {
    return false;
  }
  const ControlMode m = k.law.mode;
  if (ControlLaw::NeedsBodyVelocity(m) &&
      !need(Input::kBodyVelocity,
            m == ControlMode::kSkyhookOnOff || m == ControlMode::kSkyhookContinuous ? "skyhook laws"
            : m == ControlMode::kHybrid ? "law \"hybrid\""
                                        : "law \"sh-add\"")) {
    return false;
  }
  if (ControlLaw::NeedsWheelVelocity(m) &&
      !need(Input::kWheelVelocity,
            m == ControlMode::kHybrid ? "law \"hybrid\"" : "groundhook laws")) {
    return false;
  }
  if (ControlLaw::NeedsBodyAcceleration(m) &&
      !need(Input::kBodyAcceleration, m == ControlMode::kAdd ? "law \"add\"" : "law \"sh-add\"")) {
    return false;
  }
  if (ControlLaw::NeedsFloorAccelerations(m)) {
    for (const Input i :
         {Input::kFloorAcceleration1, Input::kFloorAcceleration2, Input::kFloorAcceleration3}) {
      if (!need(i, "law \"clipped-optimal\"")) return false;
    }
  }
  return !ControlLaw::NeedsForce(m) || need(Input::kForce, "law \"clipped-optimal\"");
}

// Each bus knows where to connect: [can] one of interface/local_bus, a grant clock on a bus
// that carries grants, [modbus] RTU with its device.
bool CheckBusConnections(const toml::table& root, const std::string& source,
                         const FirmwareConfig& c, std::string* error) {
  const IoConfig& io = c.io;
  if (io.can.enabled && io.can.interface.empty() == io.can.local_bus.empty()) {
    *error = Where(root, source, "can", "interface") +
             "[can] needs exactly one of 'interface' (SocketCAN) and 'local_bus' (socket path)";
    return false;
  }
  if (c.clock == LoopClock::kGrant && !io.can.enabled && !io.modbus.enabled) {
    *error = Where(root, source, "loop", "clock") +
             "clock = \"grant\" needs a [can] or [modbus] section (the bus the time grants "
             "travel on)";
    return false;
  }
  if (io.modbus.enabled && io.modbus.mode == ModbusMode::kRtu && io.modbus.device.empty()) {
    *error = Where(root, source, "modbus", "mode") + "[modbus] mode \"rtu\" needs 'device'";
    return false;
  }
  return true;
}

// [gpio]: one chip (real or simulated), every line its routing uses given, no line twice.
bool CheckGpioLines(const toml::table& root, const std::string& source, const GpioConfig& g,
                    std::string* error) {
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
  return true;
}

// Routing and connection checks across the bus sections (io_config.hpp), in this order (the
// first failing one is the error): clipped-optimal gains given, the grant clock without
// buses, routing, inputs the law reads, displacement limit, command output, connections,
// [gpio] lines.
bool CheckIo(const toml::table& root, const std::string& source, const FirmwareConfig& c,
             std::string* error) {
  const IoConfig& io = c.io;
  if (c.controller.law.mode == ControlMode::kClippedOptimal && c.clipped_gains_path.empty()) {
    *error = Where(root, source, "control", "law") +
             "law \"clipped-optimal\" needs [clipped_optimal] gains (the file mrd-structure "
             "design --out writes)";
    return false;
  }
  if (!io.any()) {
    if (c.clock != LoopClock::kGrant) return true;
    *error = Where(root, source, "loop", "clock") +
             "clock = \"grant\" needs a [can] or [modbus] section (the bus the time grants "
             "travel on)";
    return false;
  }
  std::uint32_t inputs = 0, outputs = 0;
  if (!CheckBusRouting(root, source, io, &inputs, &outputs, error)) return false;
  if (!CheckLawInputsServed(source, c.controller, inputs, error)) return false;
  if (c.controller.displacement_limit > 0.0 && (inputs & Bit(Input::kDisplacement)) == 0) {
    *error = Where(root, source, "safety", "displacement_limit") +
             "displacement_limit needs a measured displacement: no bus serves input "
             "'displacement' (route it, or drop the limit)";
    return false;
  }
  if ((outputs & Bit(Output::kCommand)) == 0) {
    *error = source + ": no bus drives the 'command' output (the current driver's set-point)";
    return false;
  }
  if (!CheckBusConnections(root, source, c, error)) return false;
  return !io.gpio.enabled || CheckGpioLines(root, source, io.gpio, error);
}

// [can] profile: loaded (relative to the configuration file) and checked against the routing:
// every input and output the [can] section names, and the grant in lockstep, must be a role
// the profile maps. Without the key: the built-in mrd-native profile (checked the same way).
bool LoadCanProfileOf(const toml::table& root, const std::string& source, FirmwareConfig* c,
                      std::string* error) {
  CanConfig& can = c->io.can;
  const profile::CanProfile* p = &profile::NativeCanProfile();
  std::string where = Where(root, source, "can", "profile");
  if (!can.profile.empty()) {
    const std::string path = ResolveBeside(source, can.profile);
    auto loaded = std::make_shared<profile::CanProfile>();
    std::string why;
    if (!profile::LoadCanProfile(path, loaded.get(), &why)) {
      *error = where + "device profile: " + Printable(why);
      return false;
    }
    can.can_profile = loaded;
    p = loaded.get();
  } else {
    where = Where(root, source, "can", "inputs");
  }
  const auto mapped_in = [&](profile::CanIn r) {
    return p->inputs[static_cast<std::size_t>(r)].mapped();
  };
  const auto mapped_out = [&](profile::CanOut r) {
    return p->outputs[static_cast<std::size_t>(r)].mapped();
  };
  for (const InputRole& m : kInputRoles) {
    if ((can.inputs & Bit(m.input)) != 0 && !mapped_in(m.role)) {
      *error = where + "profile " + p->name + " maps no signal to input '" + InputName(m.input) +
               "' ([inputs] of the profile)";
      return false;
    }
  }
  struct Need {
    Output output;
    std::initializer_list<profile::CanOut> any;
  };
  const Need needs[] = {{Output::kCommand, {profile::CanOut::kCommand}},
                        {Output::kEnable, {profile::CanOut::kEnable}},
                        {Output::kHeartbeat, {profile::CanOut::kHeartbeatSafe}},
                        {Output::kStatus,
                         {profile::CanOut::kStatusSafe, profile::CanOut::kStatusCauses,
                          profile::CanOut::kStatusOverruns, profile::CanOut::kStatusSafeEntries}}};
  for (const Need& n : needs) {
    if ((can.outputs & Bit(n.output)) == 0) continue;
    bool any = false;
    for (const profile::CanOut r : n.any) any = any || mapped_out(r);
    // A CANopen drive watches the firmware's CANopen heartbeat (0x700 + own node).
    if (n.output == Output::kHeartbeat && p->canopen && p->canopen->heartbeat_ns > 0) any = true;
    if (!any) {
      *error = where + "profile " + p->name + " maps no signal to output '" + OutputName(n.output) +
               "' ([outputs] of the profile)";
      return false;
    }
  }
  // The fault_reset bit travels in the command frames: they go out only with command or enable.
  if (mapped_out(profile::CanOut::kFaultReset) &&
      (can.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) == 0) {
    *error = where + "profile " + p->name +
             " maps fault_reset, which goes out in the command frames: route 'command' or "
             "'enable' to [can] outputs";
    return false;
  }
  if (c->clock == LoopClock::kGrant && !mapped_in(profile::CanIn::kGrant)) {
    *error = where + "clock = \"grant\" needs the profile's 'grant' input (profile " + p->name +
             " has none)";
    return false;
  }
  return true;
}

// [modbus] profile: loaded (relative to the configuration file) and checked against the
// routing: every input and output the [modbus] section names, and the grant in lockstep
// (grants on Modbus: no [can] bus), must be a role the profile maps. fault_line is served by
// the profile's fault_line or driver_faults role.
bool LoadModbusProfileOf(const toml::table& root, const std::string& source, FirmwareConfig* c,
                         std::string* error) {
  ModbusConfig& mb = c->io.modbus;
  if (mb.profile.empty()) {
    // The built-in register map (docs/modbus_registers.md) has no chassis or structure
    // registers.
    for (const Input i :
         {Input::kBodyAcceleration, Input::kWheelVelocity, Input::kFloorAcceleration1,
          Input::kFloorAcceleration2, Input::kFloorAcceleration3}) {
      if ((mb.inputs & Bit(i)) != 0) {
        *error = Where(root, source, "modbus", "inputs") + "input '" + InputName(i) +
                 "' needs a Modbus device profile (the built-in register map has none)";
        return false;
      }
    }
    return true;
  }
  const std::string where = Where(root, source, "modbus", "profile");
  const std::string path = ResolveBeside(source, mb.profile);
  auto p = std::make_shared<profile::ModbusProfile>();
  std::string why;
  if (!profile::LoadModbusProfile(path, p.get(), &why)) {
    *error = where + "device profile: " + Printable(why);
    return false;
  }
  const auto in = [&](profile::CanIn r) { return p->In(r).mapped; };
  const auto out = [&](profile::ModbusOut r) { return p->Out(r).mapped; };
  for (const InputRole& m : kInputRoles) {
    const bool mapped =
        in(m.role) || (m.role == profile::CanIn::kFaultLine && in(profile::CanIn::kDriverFaults));
    if ((mb.inputs & Bit(m.input)) != 0 && !mapped) {
      *error = where + "profile " + p->name + " maps no register to input '" + InputName(m.input) +
               "' ([modbus.inputs] of the profile)";
      return false;
    }
  }
  const std::pair<Output, bool> needs[] = {
      {Output::kCommand, out(profile::ModbusOut::kCommand)},
      {Output::kEnable, out(profile::ModbusOut::kEnable)},
      {Output::kHeartbeat, out(profile::ModbusOut::kHeartbeat)},
      {Output::kStatus, out(profile::ModbusOut::kStatusSafe) ||
                            out(profile::ModbusOut::kStatusCauses) ||
                            out(profile::ModbusOut::kStatusOverruns) ||
                            out(profile::ModbusOut::kStatusSafeEntries)}};
  for (const auto& [output, mapped] : needs) {
    if ((mb.outputs & Bit(output)) != 0 && !mapped) {
      *error = where + "profile " + p->name + " maps no register to output '" + OutputName(output) +
               "' ([modbus.outputs] of the profile)";
      return false;
    }
  }
  if (c->clock == LoopClock::kGrant && !c->io.can.enabled && !in(profile::CanIn::kGrant)) {
    *error = where + "clock = \"grant\" needs the profile's 'grant' input (profile " + p->name +
             " has none)";
    return false;
  }
  mb.modbus_profile = p;
  return true;
}

// [pwm] profile: the file the key names (relative to the configuration file), else the [can]
// section's profile file; it must have a [pwm] section (pwm_profile.hpp).
bool LoadPwmProfileOf(const toml::table& root, const std::string& source, FirmwareConfig* c,
                      std::string* error) {
  PwmOutputConfig& pwm = c->io.pwm;
  std::string where = Where(root, source, "pwm", "profile");
  std::string file = pwm.profile;
  if (file.empty()) {
    file = c->io.can.profile;
    where = Where(root, source, "pwm", "outputs");
    if (file.empty()) {
      *error = where +
               "[pwm] needs a device profile with a [pwm] section: give 'profile' (or a "
               "[can] profile that has one)";
      return false;
    }
  }
  file = ResolveBeside(source, file);
  auto loaded = std::make_shared<profile::PwmProfile>();
  std::string why;
  if (!profile::LoadPwmProfile(file, loaded.get(), &why)) {
    *error = where + "device profile: " + Printable(why);
    return false;
  }
  pwm.pwm_profile = loaded;
  return true;
}

bool Apply(const toml::table& root, const std::string& source, FirmwareConfig* c,
           std::string* error) {
  Scratch x{static_cast<double>(c->period_ns) / 1e3,
            static_cast<double>(c->controller.watchdog.max_age_ns) / 1e6, c->e_max.value_or(NAN)};
  ControllerConfig& k = c->controller;
  const Sections sections = KeyTable(c, &x);
  auto fail = [&](const toml::node& n, const std::string& what) {  // what may echo input
    *error = source + ":" + std::to_string(n.source().begin.line) + ": " + Printable(what);
    return false;
  };
  for (const auto& [name, node] : root) {
    const auto section = std::find_if(sections.begin(), sections.end(),
                                      [&](const auto& sec) { return sec.first == name.str(); });
    if (section == sections.end())
      return fail(node, "unknown section '" + std::string(name.str()) + "'");
    const toml::table* tbl = node.as_table();
    if (tbl == nullptr) return fail(node, "'" + std::string(name.str()) + "' must be a table");
    if (name.str() == "can") c->io.can.enabled = true;
    if (name.str() == "modbus") c->io.modbus.enabled = true;
    if (name.str() == "gpio") c->io.gpio.enabled = true;
    if (name.str() == "pwm") c->io.pwm.enabled = true;
    for (const auto& [key, value] : *tbl) {
      const auto entry = std::find_if(section->second.begin(), section->second.end(),
                                      [&](const Key& e) { return key.str() == e.name; });
      if (entry == section->second.end()) {
        return fail(value,
                    "unknown key '" + std::string(key.str()) + "' in [" + section->first + "]");
      }
      std::string why;
      if (!entry->set(value, &why)) {
        return fail(value, "'" + std::string(key.str()) + "' " + why);
      }
    }
  }
  if (!CheckIo(root, source, *c, error)) return false;
  if (!c->clipped_gains_path.empty()) {  // relative to the config file
    const std::string path = ResolveBeside(source, c->clipped_gains_path);
    std::string why;
    if (!LoadClippedOptimalGains(path, &k.clipped_gains, &why)) {
      *error = Where(root, source, "clipped_optimal", "gains") +
               "[clipped_optimal] gains: " + Printable(why);
      return false;
    }
    k.clipped_gains_loaded = true;
  }
  if (c->io.can.enabled && !LoadCanProfileOf(root, source, c, error)) return false;
  if (c->io.modbus.enabled && !LoadModbusProfileOf(root, source, c, error)) return false;
  if (c->io.pwm.enabled && !LoadPwmProfileOf(root, source, c, error)) return false;
  // Relative to the config file; beside a bare config name it already is (kept as given).
  if (!c->log.path.empty() && source.find('/') != std::string::npos) {
    c->log.path = ResolveBeside(source, c->log.path);
  }
  runlog::Header log_header;
  log_header.fields = PeriodLogFields();
  const std::uint64_t block_bytes =
      runlog::kBlockHeaderBytes + std::uint64_t{c->log.block_records} * log_header.record_bytes();
  if (runlog::EncodeHeader(log_header).size() + block_bytes > c->log.max_bytes) {
    *error = Where(root, source, "log", "max_bytes") + "[log] max_bytes " +
             std::to_string(c->log.max_bytes) + " is smaller than the header and one block of " +
             std::to_string(c->log.block_records) + " records (" + std::to_string(block_bytes) +
             " bytes)";
    return false;
  }
  c->period_ns = static_cast<std::int64_t>(std::llround(x.period_us * 1e3));
  k.watchdog.max_age_ns = static_cast<std::int64_t>(std::llround(x.max_age_ms * 1e6));
  if (x.e_max_set) c->e_max = x.e_max;
  if (!c->ctl_socket.empty()) c->ctl_enable = true;
  // Grants travel on CAN when there is a CAN bus, else on Modbus.
  c->io.can.lockstep = c->clock == LoopClock::kGrant;
  c->io.modbus.lockstep = c->clock == LoopClock::kGrant && !c->io.can.enabled;
  c->io.can.max_age_ns = k.watchdog.max_age_ns;  // the CAN device's last check before sending
  c->io.modbus.priority = c->priority;           // the worker that writes the loop's safe block
  c->io.can.period_ns = c->period_ns;
  c->io.modbus.period_ns = c->period_ns;
  c->io.pwm.period_ns = c->period_ns;
  c->io.pwm.safe_volts = k.safe_voltage;
  // The safe state on the wire (E_max: the configuration's, else the compiled-in table's; the
  // start proves it again with the table it runs on).
  const SafeStateProof proof = ProveSafeState(*c, c->e_max.value_or(kBuiltinTable.e_max));
  if (!proof.error.empty()) {
    *error = Where(root, source, proof.section, proof.key) + Printable(proof.error);
    return false;
  }
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
        "`firmware/platform/src/config.cpp` (a test checks that this file equals its output).\n\n"
        "`mrd-firmware --config FILE.toml` reads TOML once at start-up. Every key is optional;\n"
        "an unknown section or key, a wrong type or a value out of range is an error\n"
        "(`error: FILE:LINE: reason`, exit 2; input the reason echoes is shown with control\n"
        "bytes as `\\xNN` and cut at 400 characters). The file must be a regular file of at most\n"
        "1 MiB (a directory, FIFO or device is refused without reading it). `--check-config`\n"
        "refuses every value the start would refuse for its form (routing, lengths,\n"
        "characters); an interface, host or device that is missing shows only at start.\n\n"
        "Column *set*: `runtime` keys can change while the firmware runs (`mrd-firmware ctl\n"
        "set`, applied at a period boundary; docs/tuning.md) and on a reload (SIGHUP);\n"
        "`reload` keys on a reload only; `restart` keys need a restart (a reload that changes\n"
        "one is refused).\n";
    for (const auto& [section, keys] : KeyTable(&c, &x)) {
      out += "\n## [" + section + "]\n\n";
      out += "| key | default | unit | accepts | set | meaning |\n|---|---|---|---|---|---|\n";
      for (const Key& key : keys) {
        const std::string def = key.show();
        std::string accepts;  // '|' would end the Markdown cell
        for (const char ch : key.accepts)
          accepts += ch == '|' ? std::string("or") : std::string(1, ch);
        out += std::string("| `") + key.name + "` | " +
               (def.empty()     ? std::string("table's")
                : def[0] == '(' ? def.substr(1, def.size() - 2)
                                : "`" + def + "`") +
               " | " + key.unit + " | " + accepts + " | " + TunableName(key.tunable) + " | " +
               key.description + " |\n";
      }
    }
    return out;
  } catch (const std::exception&) {
    return "";
  }
}

const char* TunableName(Tunable t) {
  switch (t) {
    case Tunable::kRestart:
      return "restart";
    case Tunable::kReload:
      return "reload";
    case Tunable::kRuntime:
      return "runtime";
  }
  return "restart";
}

std::string DefaultCtlSocket() {
  const char* xdg = std::getenv("XDG_RUNTIME_DIR");
  if (xdg != nullptr && xdg[0] == '/') return std::string(xdg) + "/mrd-firmware.sock";
  return "/run/mrd-firmware/ctl.sock";
}

namespace {

Scratch ScratchOf(const FirmwareConfig& c) {
  return Scratch{static_cast<double>(c.period_ns) / 1e3,
                 static_cast<double>(c.controller.watchdog.max_age_ns) / 1e6, c.controller.e_max};
}

}  // namespace

std::vector<ParamInfo> ListParams(const FirmwareConfig& config) {
  std::vector<ParamInfo> out;
  try {
    FirmwareConfig c = config;
    Scratch x = ScratchOf(c);
    for (const auto& [section, keys] : KeyTable(&c, &x)) {
      for (const Key& key : keys) {
        ParamInfo p;
        p.name = section + "." + key.name;
        p.value = p.name == "control.e_max" ? Show(c.controller.e_max) : key.show();
        p.type = key.type;
        p.unit = key.unit;
        p.accepts = key.accepts;
        p.tunable = key.tunable;
        out.push_back(std::move(p));
      }
    }
  } catch (const std::exception&) {  // std::bad_alloc: what was listed
  }
  return out;
}

bool SetParam(FirmwareConfig* config, std::string_view name, std::string_view value,
              std::string* why) {
  try {
    FirmwareConfig c = *config;
    Scratch x = ScratchOf(c);
    const Sections sections = KeyTable(&c, &x);
    const Key* key = nullptr;
    for (const auto& [section, keys] : sections) {
      for (const Key& k : keys) {
        if (name == section + "." + k.name) key = &k;
      }
    }
    const std::string shown = Printable(name);
    if (key == nullptr) {
      *why = "unknown parameter '" + shown + "' (mrd-firmware ctl list names them)";
      return false;
    }
    if (key->tunable != Tunable::kRuntime) {
      *why = shown + " is not tunable at runtime: " +
             (key->tunable == Tunable::kReload ? "change it in the config file and reload (SIGHUP)"
                                               : "it needs a restart");
      return false;
    }
    // The value as TOML; a bare word (not TOML) as a string.
    toml::table doc;
    bool parsed = false;
    if (value.find_first_of("\n\r") == std::string_view::npos) {
      try {
        doc = toml::parse("v = " + std::string(value));
        parsed = doc.size() == 1;
      } catch (const toml::parse_error&) {
      }
    }
    if (!parsed) {
      doc = toml::table{};
      doc.insert_or_assign("v", std::string(value));
    }
    std::string reason;
    if (!key->set(*doc.get("v"), &reason)) {
      *why = shown + " = " + Printable(value) + ": " + Printable(reason);
      return false;
    }
    if (x.e_max_set) {
      c.e_max = x.e_max;
      c.controller.e_max = x.e_max;
    }
    // The bus routing must still serve what the value needs (e.g. a law's inputs).
    const toml::table none;
    if (!CheckIo(none, "", c, &reason)) {
      for (const char* prefix : {":0: ", ": "}) {
        if (reason.rfind(prefix, 0) == 0) reason.erase(0, std::strlen(prefix));
      }
      *why = shown + " = " + Printable(value) + ": " + reason;
      return false;
    }
    *config = c;
    return true;
  } catch (const std::exception& e) {  // std::bad_alloc
    *why = e.what();
    return false;
  }
}

std::vector<std::string> RestartKeysChanged(const FirmwareConfig& running,
                                            const FirmwareConfig& next) {
  std::vector<std::string> out;
  try {
    FirmwareConfig a = running, b = next;
    Scratch xa = ScratchOf(a), xb = ScratchOf(b);
    const Sections ka = KeyTable(&a, &xa), kb = KeyTable(&b, &xb);
    for (std::size_t s = 0; s < ka.size() && s < kb.size(); ++s) {
      for (std::size_t i = 0; i < ka[s].second.size() && i < kb[s].second.size(); ++i) {
        const Key& k = ka[s].second[i];
        if (k.tunable == Tunable::kRestart && k.show() != kb[s].second[i].show()) {
          out.push_back(ka[s].first + "." + k.name);
        }
      }
    }
    const std::pair<const char*, bool> buses[] = {
        {"[can]", a.io.can.enabled != b.io.can.enabled},
        {"[modbus]", a.io.modbus.enabled != b.io.modbus.enabled},
        {"[gpio]", a.io.gpio.enabled != b.io.gpio.enabled},
        {"[pwm]", a.io.pwm.enabled != b.io.pwm.enabled}};
    for (const auto& [section, changed] : buses) {
      if (changed) out.emplace_back(section);
    }
  } catch (const std::exception&) {
    out.emplace_back("(out of memory comparing the configs)");
  }
  return out;
}

bool ParseConfig(std::string_view text, const std::string& source, FirmwareConfig* config,
                 std::string* error) {
  try {
    const std::string shown = Printable(source);  // messages echo it
    try {
      const toml::table root = toml::parse(text, source);
      FirmwareConfig c = *config;
      if (!Apply(root, shown, &c, error)) return false;
      *config = c;
      return true;
    } catch (const toml::parse_error& e) {
      *error =
          shown + ":" + std::to_string(e.source().begin.line) + ": " + Printable(e.description());
      return false;
    }
  } catch (const std::exception& e) {  // std::bad_alloc
    *error = Printable(source) + ": " + e.what();
    return false;
  }
}

bool LoadConfigFile(const std::string& path, FirmwareConfig* config, std::string* error) {
  try {
    std::string text;
    if (!ReadInputFile(path, kMaxConfigBytes, &text, error)) return false;
    return ParseConfig(text, path, config, error);
  } catch (const std::exception& e) {  // std::bad_alloc
    *error = Printable(path) + ": " + e.what();
    return false;
  }
}

}  // namespace mrd::firmware
