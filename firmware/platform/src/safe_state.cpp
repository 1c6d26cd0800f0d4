// The safe state proved from the configuration (safe_state.hpp): each bus's safe command
// encoded with the device's own codec (CAN: the profile's FrameCodec; Modbus: the profile's
// register codec or the built-in map; PWM: the profile's duty mapping) and decoded back.
#include "mrd/firmware/platform/safe_state.hpp"

#include <linux/can.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>

#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/profile/pwm_profile.hpp"
#include "mrd/protocol/can_signal.hpp"
#include "mrd/protocol/modbus_map.hpp"

namespace mrd::firmware::platform {
namespace {

namespace pf = profile;

std::string Num(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

// The proof's verdict on one bus: blame the safe voltage when it is not 0 V (the shutdown at
// 0 V is the profile's own, proved by its loader), else the profile.
void Refuse(SafeStateProof* p, const std::string& why, double safe_v, const char* bus) {
  p->error = why;
  p->section = safe_v != 0.0 ? "safety" : bus;
  p->key = safe_v != 0.0 ? "safe_voltage" : "profile";
}

// CAN: the command message as SendCommand fills it for a safe command of e [V], on the device
// profile p (the [can] one, or a channel's of [channels] can_profiles).
void ProveCan(const FirmwareConfig& c, const pf::CanProfile& p, double e_max,
              SafeStateProof* proof) {
  const CanConfig& can = c.io.can;
  if ((can.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) == 0) return;
  const pf::SignalRef cmd = p.outputs[static_cast<std::size_t>(pf::CanOut::kCommand)];
  const pf::SignalRef en = p.outputs[static_cast<std::size_t>(pf::CanOut::kEnable)];
  const bool command_here = (can.outputs & Bit(Output::kCommand)) != 0 && cmd.mapped();
  const double safe_v = c.controller.safe_voltage;
  pf::FrameCodec codec(p);
  const auto name = [&](pf::SignalRef r) {
    const pf::DbcMessage& m = p.dbc.messages[static_cast<std::size_t>(r.message)];
    return m.name + "." + m.signals[static_cast<std::size_t>(r.signal)].name;
  };
  // The set-point's raw bits for a safe command of e [V]; false when it cannot be carried.
  const auto raw = [&](double setpoint, std::int64_t* out) {
    can_frame f{};
    codec.Begin(cmd.message, &f);
    if (codec.Set(&f, cmd, setpoint) != protocol::SignalError::kNone) return false;
    *out = protocol::ExtractRaw(f.data, p.Layout(cmd));
    return true;
  };
  std::string line = "can (" + p.name + "):";
  if (command_here) {
    const pf::CommandMap& m = p.command;
    std::int64_t off = 0, safe = 0, shut = 0;
    if (!raw(m.Off(), &off)) {
      return Refuse(proof,
                    "the driver's off (" + Num(m.Off()) + " " + p.command_unit +
                        ") cannot be carried by " + name(cmd),
                    0.0, "can");
    }
    if (!raw(m.SafeSetpoint(safe_v), &safe) || safe != off) {
      return Refuse(proof,
                    "the safe state (safe_voltage " + Num(safe_v) + " V) puts " +
                        Num(m.SafeSetpoint(safe_v)) + " " + p.command_unit + " on " + name(cmd) +
                        ", not the driver's off (" + Num(m.Off()) + " " + p.command_unit + ")",
                    safe_v, "can");
    }
    if (!raw(m.SafeSetpoint(0.0), &shut) || shut != off) {  // the profile loader proves it too
      return Refuse(proof, "the shutdown's 0 V is not the driver's off on " + name(cmd), 0.0,
                    "can");
    }
    for (const double e : {0.0, e_max}) {  // monotonic: the ends bound every command
      std::int64_t r = 0;
      if (!raw(m.SafeSetpoint(e), &r)) {
        proof->error = "E_max " + Num(e_max) + " V gives " + Num(m.SafeSetpoint(e)) + " " +
                       p.command_unit + ", beyond what " + name(cmd) +
                       " can carry: such commands would be refused on the wire and replaced by "
                       "the safe state; lower e_max or give the profile a [command] range";
        proof->section = "control";
        proof->key = "e_max";
        return;
      }
    }
    line += " " + name(cmd) + " = " + Num(m.SafeSetpoint(safe_v)) + " " + p.command_unit;
  }
  if (en.mapped()) {
    can_frame f{};
    codec.Begin(en.message, &f);
    double back = 1.0;
    if (codec.Set(&f, en, 0.0) != protocol::SignalError::kNone ||
        codec.Get(f, en, &back) != protocol::SignalError::kNone || back != 0.0) {
      return Refuse(proof, "the enable " + name(en) + " cannot carry 0 (off)", 0.0, "can");
    }
    line += ", " + name(en) + " = 0";
  }
  const pf::SignalRef sf = p.outputs[static_cast<std::size_t>(pf::CanOut::kSafe)];
  if (sf.mapped()) line += ", " + name(sf) + " = 1";
  proof->lines.push_back(line + " (safe state and shutdown)");
}

// Modbus on a profile (the [modbus] one, or a channel's of [channels] modbus_profiles): the
// values WriteProfileOnce writes for a safe command.
void ProveModbusProfile(const FirmwareConfig& c, const pf::ModbusProfile& p, double e_max,
                        SafeStateProof* proof) {
  const ModbusConfig& mb = c.io.modbus;
  const pf::ModbusPoint& cmd = p.Out(pf::ModbusOut::kCommand);
  const pf::ModbusPoint& en = p.Out(pf::ModbusOut::kEnable);
  const double safe_v = c.controller.safe_voltage;
  const auto words = [&](const pf::ModbusPoint& pt, double v, std::uint32_t* out) {
    pf::ModbusPoint at = pt;
    at.index = 0;
    std::uint16_t w[2] = {0, 0};
    if (!pf::PutModbusPoint(p, at, v, w)) return false;
    *out = (std::uint32_t{w[0]} << 16) | w[1];
    return true;
  };
  std::string line = "modbus (" + p.name + "):";
  if (cmd.mapped) {
    const pf::CommandMap& m = p.command;
    // Routed: the loop's safe set-point; not routed: the device's own (E = 0 V).
    const double sp =
        (mb.outputs & Bit(Output::kCommand)) != 0 ? m.SafeSetpoint(safe_v) : m.SafeSetpoint(0.0);
    std::uint32_t off = 0, safe = 0;
    if (!words(cmd, m.Off(), &off) || !words(cmd, sp, &safe) || safe != off) {
      return Refuse(proof,
                    "the safe state (safe_voltage " + Num(safe_v) + " V) writes " + Num(sp) + " " +
                        p.command_unit + " to the command register, not the driver's off (" +
                        Num(m.Off()) + " " + p.command_unit + ")",
                    safe_v, "modbus");
    }
    for (const double e : {0.0, e_max}) {
      std::uint32_t w = 0;
      if ((mb.outputs & Bit(Output::kCommand)) != 0 && !words(cmd, m.SafeSetpoint(e), &w)) {
        proof->error = "E_max " + Num(e_max) + " V gives " + Num(m.SafeSetpoint(e)) + " " +
                       p.command_unit +
                       ", beyond what the command register can hold: such commands would be "
                       "refused and replaced by the safe state; lower e_max or give the "
                       "profile a [command] range";
        proof->section = "control";
        proof->key = "e_max";
        return;
      }
    }
    line += " command = " + Num(sp) + " " + p.command_unit;
  }
  if (en.mapped) {
    std::uint32_t w = 1;
    if (!words(en, 0.0, &w) || w != 0) {
      return Refuse(proof, "the enable register cannot carry 0 (off)", 0.0, "modbus");
    }
    line += ", enable = 0";
  }
  if (p.Out(pf::ModbusOut::kSafe).mapped) line += ", safe = 1";
  proof->lines.push_back(line + " (safe state and shutdown)");
}

// Modbus on the built-in map: the set-point register holds 1 mV steps (+-32.767 V).
void ProveModbus(const FirmwareConfig& c, double e_max, SafeStateProof* proof) {
  const ModbusConfig& mb = c.io.modbus;
  if ((mb.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) == 0) return;
  if (mb.modbus_profile) return ProveModbusProfile(c, *mb.modbus_profile, e_max, proof);
  const double safe_v = c.controller.safe_voltage;
  if ((mb.outputs & Bit(Output::kCommand)) != 0) {
    if (std::lround(safe_v * 1000.0) != 0) {
      return Refuse(proof,
                    "the safe state (safe_voltage " + Num(safe_v) +
                        " V) writes a set-point that is not the driver's off (0 V)",
                    safe_v, "modbus");
    }
    protocol::modbus::CommandBlock b;
    b.has_set_point = true;
    b.set_point = e_max;
    std::uint16_t regs[protocol::modbus::kCommandCount] = {};
    if (protocol::modbus::EncodeCommand(b, regs) != protocol::modbus::MapError::kOk) {
      proof->error =
          "E_max " + Num(e_max) + " V is beyond the built-in map's set-point register (+-32.767 V)";
      proof->section = "control";
      proof->key = "e_max";
      return;
    }
  }
  proof->lines.push_back(
      "modbus (built-in map): set_point = 0 V, state = safe, enable = 0 "
      "(safe state and shutdown)");
}

// PWM: the duty PwmDevice writes for a safe command.
void ProvePwm(const FirmwareConfig& c, SafeStateProof* proof) {
  const PwmOutputConfig& pwm = c.io.pwm;
  if (!pwm.enabled || !pwm.pwm_profile) return;
  const pf::PwmProfile& p = *pwm.pwm_profile;
  const double safe_v = c.controller.safe_voltage;
  const std::int64_t off = p.DutyNs(p.SetpointToDuty(p.command.Off()));
  const std::int64_t safe = p.DutyNs(p.SetpointToDuty(p.command.SafeSetpoint(safe_v)));
  if (safe != off) {
    return Refuse(proof,
                  "the safe state (safe_voltage " + Num(safe_v) + " V) gives a PWM duty of " +
                      std::to_string(safe) + " ns, not the driver's off (" + std::to_string(off) +
                      " ns)",
                  safe_v, "pwm");
  }
  proof->lines.push_back("pwm (" + p.name + "): duty " + std::to_string(safe) + " of " +
                         std::to_string(p.period_ns) + " ns (safe state; 0 at shutdown)");
}

// Channel i's proof on bus ("can": its line "can (..." becomes "can channel i (..."); a
// refusal names the channel and, when it blames the bus section, [channels] key. false: refused.
bool ChannelProved(std::size_t i, const char* bus, const char* key, std::size_t lines,
                   SafeStateProof* proof) {
  if (!proof->error.empty()) {
    proof->error = "channel " + std::to_string(i) + ": " + proof->error;
    if (std::strcmp(proof->section, bus) == 0) {
      proof->section = "channels";
      proof->key = key;
    }
    return false;
  }
  if (proof->lines.size() > lines) {
    proof->lines.back().insert(std::strlen(bus), " channel " + std::to_string(i));
  }
  return true;
}

}  // namespace

SafeStateProof ProveSafeState(const FirmwareConfig& c, double e_max) {
  SafeStateProof proof;
  if (c.io.can.enabled && c.channels.can_device_profiles.empty()) {
    ProveCan(c, c.io.can.can_profile ? *c.io.can.can_profile : pf::NativeCanProfile(), e_max,
             &proof);
  }
  // Several channels on [can]: each channel's profile ([channels] can_profiles).
  for (std::size_t i = 0; c.io.can.enabled && i < c.channels.can_device_profiles.size(); ++i) {
    const std::size_t lines = proof.lines.size();
    ProveCan(c, *c.channels.can_device_profiles[i], e_max, &proof);
    if (!ChannelProved(i, "can", "can_profiles", lines, &proof)) break;
  }
  // Several channels on [modbus]: each channel's map ([channels] modbus_profiles).
  const auto& maps = c.channels.modbus_device_profiles;
  const bool mb_outputs =
      (c.io.modbus.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) != 0;
  for (std::size_t i = 0;
       proof.error.empty() && c.io.modbus.enabled && mb_outputs && i < maps.size(); ++i) {
    const std::size_t lines = proof.lines.size();
    ProveModbusProfile(c, *maps[i], e_max, &proof);
    if (!ChannelProved(i, "modbus", "modbus_profiles", lines, &proof)) break;
  }
  if (proof.error.empty() && c.io.modbus.enabled && maps.empty()) ProveModbus(c, e_max, &proof);
  if (proof.error.empty()) ProvePwm(c, &proof);
  if (proof.error.empty() && c.io.gpio.enabled && c.io.gpio.enable_line >= 0 &&
      (c.io.gpio.outputs & Bit(Output::kEnable)) != 0) {
    proof.lines.push_back("gpio: enable line " + std::to_string(c.io.gpio.enable_line) +
                          " inactive (safe state and shutdown)");
  }
  return proof;
}

}  // namespace mrd::firmware::platform
