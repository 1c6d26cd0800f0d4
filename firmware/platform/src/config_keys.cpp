// Every configuration key (config_parts.hpp): how it parses, its default and its line in the
// reference (docs/firmware_config.md). The key table is the single source of all three.
#include <cmath>
#include <sstream>

#include "config_parts.hpp"
#include "mrd/firmware/io/input_roles.hpp"

namespace mrd::firmware::platform::config_detail {

std::string Show(double v) {
  std::ostringstream s;
  s << v;
  std::string t = s.str();
  if (t.find_first_not_of("-0123456789") == std::string::npos) t += ".0";  // stays a TOML float
  return t;
}

namespace {

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

}  // namespace

// [channels]: several damper channels (channels_config.hpp).
std::vector<Key> ChannelKeys(ChannelsConfig* ch) {
  BodyGeometry& g = ch->geometry;
  std::uint32_t* given = &ch->geometry_given;
  return {
      Integer("count", &ch->count, 1, static_cast<std::int64_t>(kMaxChannels), "",
              "Damper channels on the loop: with --dry-run each on a simulated damper of its "
              "own; with [can] each on its own device of the one bus (can_profiles); with "
              "[modbus] each on its own register map of the one link (modbus_profiles). "
              "[gpio], [pwm] and [ctl] serve one channel only (refused with count > 1)."),
      Choice("fault_policy", &ch->fault_policy,
             {{"all", FaultPolicy::kAll}, {"channel", FaultPolicy::kChannel}},
             "A channel's fault puts every channel in the safe state one period later "
             "(\"all\", the vehicle default) or that channel only (\"channel\")."),
      FileList("tables", &ch->tables, "the run's table",
               "Each channel's coefficient table, relative to this file, one per channel; a "
               "table may be named several times (its model is loaded once). Default: the "
               "run's table (--table, else the compiled-in one) for every channel."),
      FileList("can_profiles", &ch->can_profiles, "none: [can] profile, one channel",
               "Each channel's CAN device profile, relative to this file, one per channel "
               "(exactly count entries), e.g. a CANopen drive per corner on one bus; the "
               "[can] section (bus, inputs, outputs, timing) serves every channel and must "
               "not name a profile. Needed for count > 1 with [can]."),
      FileList("modbus_profiles", &ch->modbus_profiles, "none: [modbus] profile, one channel",
               "Each channel's Modbus device profile (its register map), relative to this "
               "file, one per channel (exactly count entries), e.g. one driver with a set-point "
               "block per corner; the [modbus] section (link, inputs, outputs, timing) serves "
               "every channel over one link and must not name a profile. Needed for count > 1 "
               "with [modbus]; not with can_profiles (one bus for several channels)."),
      Choice("body_law", &ch->body_law,
             {{"none", BodyLawKind::kNone}, {"modal-skyhook", BodyLawKind::kModalSkyhook}},
             "A law over the whole body: \"modal-skyhook\" (count = 4 in the order "
             "front-left, front-right, rear-left, rear-right; [control] law = \"force\"; "
             "the geometry below) sets each corner's force demand from the heave, pitch "
             "and roll rates of the four body velocities."),
      GeometryKey(Number("cg_to_front_m", &g.cg_to_front_m, 1e-3, 100.0, "m",
                         "modal-skyhook: centre of gravity to the front axle."),
                  given, 1U),
      GeometryKey(Number("cg_to_rear_m", &g.cg_to_rear_m, 1e-3, 100.0, "m",
                         "modal-skyhook: centre of gravity to the rear axle."),
                  given, 2U),
      GeometryKey(Number("track_front_m", &g.track_front_m, 1e-3, 100.0, "m",
                         "modal-skyhook: front track (left to right wheel)."),
                  given, 4U),
      GeometryKey(
          Number("track_rear_m", &g.track_rear_m, 1e-3, 100.0, "m", "modal-skyhook: rear track."),
          given, 8U),
      GeometryKey(Number("motion_ratio", &g.motion_ratio, 1e-3, 1.0, "",
                         "modal-skyhook: damper travel / wheel travel."),
                  given, 16U),
      Number("heave_n_s_per_m", &ch->gains.heave_n_s_per_m, 0.0, 1e9, "N s/m",
             "modal-skyhook: heave damping on the body's vertical velocity."),
      Number("pitch_n_m_s_per_rad", &ch->gains.pitch_n_m_s_per_rad, 0.0, 1e9, "N m s/rad",
             "modal-skyhook: pitch damping on the pitch rate."),
      Number("roll_n_m_s_per_rad", &ch->gains.roll_n_m_s_per_rad, 0.0, 1e9, "N m s/rad",
             "modal-skyhook: roll damping on the roll rate."),
  };
}

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
      {"channels", ChannelKeys(&c->channels)},
  };
}

}  // namespace mrd::firmware::platform::config_detail
