// Routing and connection checks across the bus sections of the configuration
// (config_parts.hpp).
#include "config_parts.hpp"

namespace mrd::firmware::platform::config_detail {

// Line of [section] key (or of the section when the key is absent).
std::string Where(const toml::table& root, const std::string& source, const char* section,
                  const char* key) {
  const toml::node* sec = root.get(section);
  const toml::node* n = sec != nullptr && sec->is_table() ? sec->as_table()->get(key) : nullptr;
  const toml::node* at = n != nullptr ? n : sec;
  const auto line = at != nullptr ? at->source().begin.line : 0U;
  return source + ":" + std::to_string(line) + ": ";
}

namespace {

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

}  // namespace

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

}  // namespace mrd::firmware::platform::config_detail
