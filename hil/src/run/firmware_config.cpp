// The mrd-firmware configuration `mrd-hil run` generates for a scenario and a transport
// (keys: docs/firmware_config.md).
#include <algorithm>
#include <cmath>
#include <sstream>

#include "mrd/hil/ports/gpio_port.hpp"
#include "mrd/hil/run/run.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"

namespace mrd::hil {
namespace {

// Appends "NAME" to a TOML list being built ("[" so far, or "[..." with items).
void Add(std::string* list, const char* name) {
  *list += std::string(list->size() > 1 ? ", " : "") + "\"" + name + "\"";
}

// [loop]: 1 ms, no real-time privileges; lockstep: clocked by the harness's grants.
void WriteLoop(std::ostringstream& c, const Scenario& s, bool lockstep) {
  c << "[loop]\nperiod_us = 1000\npriority = 0\nlock_memory = false\n";
  if (lockstep) {
    c << "clock = \"grant\"\ngrant_timeout_ms = " << s.grant_timeout_ms << "\n";
  }
}

// [control] (the scenario's law; passive-off/-on and constant as a constant voltage) and,
// for clipped-optimal, [clipped_optimal].
void WriteControl(std::ostringstream& c, const Scenario& s) {
  c << "\n[control]\n";
  if (s.law == "force") {
    c << "law = \"force\"\n";
  } else if (s.law == "open-loop") {
    c << "law = \"open-loop\"\n";  // the demand carries the replayed E in mV (replay.hpp)
  } else if (s.law == "skyhook") {
    c << "law = \"skyhook\"\nskyhook_gain = " << s.skyhook_gain << "\n";
  } else if (IsChassisLaw(s.law)) {
    c << "law = \"" << s.law << "\"\ngroundhook_gain = " << s.groundhook_gain
      << "\nhybrid_gain = " << s.hybrid_gain << "\nhybrid_alpha = " << s.hybrid_alpha
      << "\nsh_add_alpha = " << s.sh_add_alpha << "\n";
  } else if (s.law == "clipped-optimal") {
    c << "law = \"clipped-optimal\"\n";
  } else {
    const double v = s.law == "passive-on"    ? s.e_max
                     : s.law == "passive-off" ? 0.0
                                              : s.constant_voltage;
    c << "law = \"constant\"\nconstant_voltage = " << v << "\n";
  }
  c << "e_max = " << s.e_max << "\n";
  if (s.law == "clipped-optimal") {
    c << "\n[clipped_optimal]\ngains = \"" << s.clipped_gains << "\"\ncommand = \""
      << s.clipped_command << "\"\n";
  }
}

// The [modbus] inputs, outputs and unit line: all signals and slave 1, or only what the
// Modbus profile maps (the profile names the units).
struct ModbusLists {
  std::string inputs = "[\"velocity\", \"displacement\", \"demand\", \"body_velocity\", \"force\"]";
  std::string outputs = "[\"command\", \"enable\", \"heartbeat\", \"status\"]";
  std::string unit = "slave = 1";
};

ModbusLists ModbusListsOf(const Scenario& s, const profile::ModbusProfile* modbus_profile) {
  ModbusLists l;
  if (modbus_profile == nullptr) return l;
  const profile::ModbusProfile& p = *modbus_profile;
  const auto in = [&](profile::CanIn r) { return p.In(r).mapped; };
  const auto out = [&](profile::ModbusOut r) { return p.Out(r).mapped; };
  std::string ins = "[";
  if (in(profile::CanIn::kVelocity)) Add(&ins, "velocity");
  if (in(profile::CanIn::kDisplacement)) Add(&ins, "displacement");
  if (in(profile::CanIn::kDemand)) Add(&ins, "demand");
  if (in(profile::CanIn::kBodyVelocity)) Add(&ins, "body_velocity");
  if (in(profile::CanIn::kForce)) Add(&ins, "force");
  // The fault input the profile maps (unless a GPIO line carries it); the driver's faults
  // count without routing.
  if (in(profile::CanIn::kFaultLine) && !s.gpio.fault_line) Add(&ins, "fault_line");
  if (IsChassisLaw(s.law) && in(profile::CanIn::kBodyAcceleration)) {
    Add(&ins, "body_acceleration");
  }
  if (IsChassisLaw(s.law) && in(profile::CanIn::kWheelVelocity)) Add(&ins, "wheel_velocity");
  if (s.law == "clipped-optimal") {
    if (in(profile::CanIn::kFloorAcceleration1)) Add(&ins, "floor_acceleration_1");
    if (in(profile::CanIn::kFloorAcceleration2)) Add(&ins, "floor_acceleration_2");
    if (in(profile::CanIn::kFloorAcceleration3)) Add(&ins, "floor_acceleration_3");
  }
  ins += "]";
  l.inputs = std::move(ins);
  std::string outs = "[\"command\"";
  if (out(profile::ModbusOut::kEnable)) outs += ", \"enable\"";
  if (out(profile::ModbusOut::kHeartbeat)) outs += ", \"heartbeat\"";
  if (out(profile::ModbusOut::kStatusSafe) || out(profile::ModbusOut::kStatusCauses)) {
    outs += ", \"status\"";
  }
  outs += "]";
  l.outputs = std::move(outs);
  l.unit = "profile = \"";  // appended piecewise: GCC 12's -Wrestrict false positive
  l.unit.append(p.path).append("\"");
  return l;
}

// [can] (and [pwm] with a PWM output). Signals on GPIO leave CAN: the motion frame's
// (displacement, velocity) for the encoder, enable and heartbeat for the lines. Only what the
// device profile maps travels on CAN.
void WriteCan(std::ostringstream& c, const Scenario& s, const std::string& endpoint,
              const profile::CanProfile* can_profile, const std::string& pwm_sysfs) {
  const ScenarioGpio& g = s.gpio;
  const profile::CanProfile& p =
      can_profile != nullptr ? *can_profile : profile::NativeCanProfile();
  const auto in = [&](profile::CanIn r) { return p.inputs[static_cast<std::size_t>(r)].mapped(); };
  const auto out = [&](profile::CanOut r) {
    return p.outputs[static_cast<std::size_t>(r)].mapped();
  };
  std::string can_inputs = "[";
  if (!g.displacement && in(profile::CanIn::kVelocity)) Add(&can_inputs, "velocity");
  if (!g.displacement && in(profile::CanIn::kDisplacement)) Add(&can_inputs, "displacement");
  if (in(profile::CanIn::kDemand)) Add(&can_inputs, "demand");
  if (in(profile::CanIn::kBodyVelocity)) Add(&can_inputs, "body_velocity");
  if (in(profile::CanIn::kForce)) Add(&can_inputs, "force");
  if (!g.fault_line && in(profile::CanIn::kFaultLine)) Add(&can_inputs, "fault_line");
  // The chassis signals only for the laws that read them (other runs keep their frame set).
  if (IsChassisLaw(s.law) && in(profile::CanIn::kBodyAcceleration)) {
    Add(&can_inputs, "body_acceleration");
  }
  if (IsChassisLaw(s.law) && in(profile::CanIn::kWheelVelocity)) {
    Add(&can_inputs, "wheel_velocity");
  }
  // The floor accelerations only for the clipped-optimal law (structure plant).
  if (s.law == "clipped-optimal") {
    if (in(profile::CanIn::kFloorAcceleration1)) Add(&can_inputs, "floor_acceleration_1");
    if (in(profile::CanIn::kFloorAcceleration2)) Add(&can_inputs, "floor_acceleration_2");
    if (in(profile::CanIn::kFloorAcceleration3)) Add(&can_inputs, "floor_acceleration_3");
  }
  can_inputs += "]";
  // With a PWM output the command leaves CAN ([pwm] below).
  std::string can_outputs = "[";
  if (pwm_sysfs.empty()) Add(&can_outputs, "command");
  if (!g.enable && out(profile::CanOut::kEnable)) Add(&can_outputs, "enable");
  const bool canopen_heartbeat = p.canopen && p.canopen->heartbeat_ns > 0;
  if (!g.heartbeat && (out(profile::CanOut::kHeartbeatSafe) || canopen_heartbeat)) {
    Add(&can_outputs, "heartbeat");
  }
  if (out(profile::CanOut::kStatusSafe) || out(profile::CanOut::kStatusCauses)) {
    Add(&can_outputs, "status");
  }
  can_outputs += "]";
  const bool local = endpoint.find('/') != std::string::npos;
  c << "\n[can]\n"
    << (local ? "local_bus" : "interface") << " = \"" << endpoint << "\"\ninputs = " << can_inputs
    << "\noutputs = " << can_outputs << "\nstatus_period_ms = 1\nheartbeat_period_ms = 10\n";
  if (can_profile != nullptr) c << "profile = \"" << can_profile->path << "\"\n";
  if (!pwm_sysfs.empty()) {
    // The set-point as a PWM duty into the harness's sysfs-ABI tree; the profile is [can]'s.
    c << "\n[pwm]\nsysfs = \"" << pwm_sysfs << "\"\nchip = 0\nchannel = 0\n"
      << "outputs = [\"command\"]\n";
  }
}

// [modbus] over TCP (endpoint HOST:PORT) or RTU (endpoint: the pty).
void WriteModbus(std::ostringstream& c, const Scenario& s, const std::string& transport,
                 bool lockstep, const std::string& endpoint,
                 const profile::ModbusProfile* modbus_profile) {
  const ModbusLists l = ModbusListsOf(s, modbus_profile);
  // Lockstep: 2 s, so a harness or firmware held up for a while (a loaded machine, SIGSTOP)
  // is waited for, not timed out: simulated time never depends on wall time.
  const int response_ms = lockstep ? 2000 : transport == "modbus-rtu" ? 10 : 20;
  if (transport == "modbus-tcp") {
    const auto colon = endpoint.rfind(':');
    c << "\n[modbus]\nmode = \"tcp\"\nhost = \"" << endpoint.substr(0, colon)
      << "\"\nport = " << endpoint.substr(colon + 1) << "\n"
      << l.unit << "\nresponse_timeout_ms = " << response_ms << "\n"
      << "retries = 1\ninputs = " << l.inputs << "\noutputs = " << l.outputs << "\n";
  } else {
    c << "\n[modbus]\nmode = \"rtu\"\ndevice = \"" << endpoint << "\"\nbaud = 115200\n"
      << l.unit << "\n"
      << "response_timeout_ms = " << response_ms << "\nretries = 1\ninputs = " << l.inputs
      << "\noutputs = " << l.outputs << "\n";
  }
}

// [velocity] (from the encoder's displacement) and [gpio]: the scenario's lines on the chip,
// at GpioPortConfig's default offsets.
void WriteGpio(std::ostringstream& c, const ScenarioGpio& g, const std::string& gpio_chip) {
  if (g.displacement) {
    c << "\n[velocity]\nsource = \"displacement\"\ncutoff_hz = " << g.velocity_cutoff_hz << "\n";
  }
  const GpioPortConfig lines;
  const bool sim = gpio_chip.find('/') != std::string::npos;
  c << "\n[gpio]\n" << (sim ? "sim_chip" : "chip") << " = \"" << gpio_chip << "\"\ninputs = [";
  const char* sep = "";
  if (g.displacement) {
    c << sep << "\"displacement\"";
    sep = ", ";
  }
  if (g.fault_line) {
    c << sep << "\"fault_line\"";
    sep = ", ";
  }
  c << "]\noutputs = [";
  sep = "";
  if (g.enable) {
    c << sep << "\"enable\"";
    sep = ", ";
  }
  if (g.heartbeat) {
    c << sep << "\"heartbeat\"";
    sep = ", ";
  }
  c << "]\nencoder_a_line = " << lines.encoder_a_line
    << "\nencoder_b_line = " << lines.encoder_b_line << "\nfault_line = " << lines.fault_line
    << "\nenable_line = " << lines.enable_line << "\nheartbeat_line = " << lines.heartbeat_line
    << "\ncounts_per_cm = " << g.counts_per_cm << "\n";
}

// [channels] of a four-corner run: the corners' profiles, the policy, the body law with the
// car's geometry (and the scenario's gains, else the firmware's defaults).
void WriteChannels(std::ostringstream& c, const Scenario& s) {
  const ScenarioChannels& ch = s.channels;
  const std::vector<std::string>& files = ch.modbus() ? ch.modbus_profiles : ch.can_profiles;
  c << "\n[channels]\ncount = " << files.size() << "\nfault_policy = \"" << ch.fault_policy
    << "\"\n"
    << (ch.modbus() ? "modbus_profiles" : "can_profiles") << " = [";
  for (std::size_t i = 0; i < files.size(); ++i) {
    c << (i > 0 ? ", " : "") << "\"" << files[i] << "\"";
  }
  c << "]\n";
  if (ch.body_law == "none") return;
  const FullCarParams& car = s.full;
  c << "body_law = \"" << ch.body_law << "\"\ncg_to_front_m = " << car.cg_to_front_m
    << "\ncg_to_rear_m = " << car.cg_to_rear_m << "\ntrack_front_m = " << car.track_front_m
    << "\ntrack_rear_m = " << car.track_rear_m << "\nmotion_ratio = " << car.motion_ratio << "\n";
  if (ch.heave_n_s_per_m) c << "heave_n_s_per_m = " << *ch.heave_n_s_per_m << "\n";
  if (ch.pitch_n_m_s_per_rad) c << "pitch_n_m_s_per_rad = " << *ch.pitch_n_m_s_per_rad << "\n";
  if (ch.roll_n_m_s_per_rad) c << "roll_n_m_s_per_rad = " << *ch.roll_n_m_s_per_rad << "\n";
}

// The generated config's head for four corners: the loop, the law, the safety and the
// [channels] section; `over` names the transport in the comment line.
void WriteCornersHead(std::ostringstream& c, const Scenario& s, const std::string& over) {
  c.precision(15);  // the geometry as written (1.4, not 1.3999999999999999)
  c << "# Generated by mrd-hil run for scenario " << s.path << " (four corners over " << over
    << ", lockstep)\n";
  WriteLoop(c, s, true);
  WriteControl(c, s);
  c << "\n[safety]\nmax_age_ms = " << s.max_age_ms << "\nrecover_periods = " << s.recover_periods
    << "\nvelocity_limit = " << s.velocity_limit << "\n";
  WriteChannels(c, s);
}

// The bus inputs every corner's profile maps as the first does, as a TOML list. The demand for
// law "force" only (the body law overwrites the bus's each period; per-corner laws read none).
template <typename Mapped>
std::string CornersInputs(const Scenario& s, Mapped mapped) {
  std::string inputs = "[";
  if (mapped(profile::CanIn::kVelocity)) Add(&inputs, "velocity");
  if (mapped(profile::CanIn::kDisplacement)) Add(&inputs, "displacement");
  if (s.law == "force" && mapped(profile::CanIn::kDemand)) Add(&inputs, "demand");
  if (mapped(profile::CanIn::kBodyVelocity)) Add(&inputs, "body_velocity");
  if (mapped(profile::CanIn::kForce)) Add(&inputs, "force");
  return inputs + "]";
}

}  // namespace

std::string CornersConfigText(const Scenario& s, const std::string& endpoint,
                              const profile::CanProfile& first) {
  std::ostringstream c;
  WriteCornersHead(c, s, "can");
  const std::string inputs = CornersInputs(
      s, [&](profile::CanIn r) { return first.inputs[static_cast<std::size_t>(r)].mapped(); });
  c << "\n[can]\nlocal_bus = \"" << endpoint << "\"\ninputs = " << inputs
    << "\noutputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n"
    << "status_period_ms = 1\nheartbeat_period_ms = 10\n";
  return c.str();
}

std::string CornersModbusConfigText(const Scenario& s, const std::string& transport,
                                    const std::string& endpoint,
                                    const profile::ModbusProfile& first) {
  std::ostringstream c;
  WriteCornersHead(c, s, transport);
  // One link; the driver's faults count without routing. Lockstep: 2 s replies, so a side
  // held up for a while is waited for (simulated time never depends on wall time).
  const std::string inputs = CornersInputs(s, [&](profile::CanIn r) { return first.In(r).mapped; });
  c << "\n[modbus]\n";
  if (transport == "modbus-tcp") {
    const auto colon = endpoint.rfind(':');
    c << "mode = \"tcp\"\nhost = \"" << endpoint.substr(0, colon)
      << "\"\nport = " << endpoint.substr(colon + 1) << "\n";
  } else {
    c << "mode = \"rtu\"\ndevice = \"" << endpoint << "\"\nbaud = 115200\n";
  }
  c << "response_timeout_ms = 2000\nretries = 1\ninputs = " << inputs
    << "\noutputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";
  return c.str();
}

std::string FirmwareConfigText(const Scenario& s, const std::string& transport, bool lockstep,
                               const std::string& endpoint, const std::string& gpio_chip,
                               const profile::CanProfile* can_profile,
                               const profile::ModbusProfile* modbus_profile,
                               const std::string& pwm_sysfs) {
  std::ostringstream c;
  const bool modbus = transport != "can";
  // In real time a Modbus transaction takes a few ms on its worker thread: the CAN defaults
  // would be stale. In lockstep the samples carry the granted time, as on CAN.
  const double max_age_ms = modbus && !lockstep && s.max_age_ms < 20.0 ? 20.0 : s.max_age_ms;
  c << "# Generated by mrd-hil run for scenario " << s.path << " (" << transport << ", "
    << (lockstep ? "lockstep" : "real time") << ")\n";
  WriteLoop(c, s, lockstep);
  WriteControl(c, s);
  c << "\n[safety]\nmax_age_ms = " << max_age_ms << "\nrecover_periods = " << s.recover_periods
    << "\nvelocity_limit = " << s.velocity_limit << "\n";
  if (!modbus) {
    WriteCan(c, s, endpoint, can_profile, pwm_sysfs);
  } else {
    WriteModbus(c, s, transport, lockstep, endpoint, modbus_profile);
  }
  if (s.gpio.any()) WriteGpio(c, s.gpio, gpio_chip);
  return c.str();
}

}  // namespace mrd::hil
