// The scenario run's first phase (run_session.hpp): options and scenario checked before
// anything starts, transport and clock parsed once, the device profile loaded. 2: bad input.
#include <algorithm>
#include <climits>
#include <cstdlib>
#include <cstring>

#include "mrd/profile/pwm_profile.hpp"
#include "run_session.hpp"

namespace mrd::hil {

ScenarioRun::ScenarioRun(const Scenario& scenario, const RunOptions& options, RunResult* r,
                         std::string* error)
    : o_(options), s_(scenario), r_(r), error_(error) {
  // The scenario's [firmware] table unless --table names one.
  if (o_.table.empty()) o_.table = scenario.table_file;
  // A profile with a PWM output (run_pwm.hpp): the driver's enable is a GPIO line, and so is the
  // heartbeat (the watchdog that drops the enable when the firmware stops).
  pwm_profile_ = !o_.profile.empty() && profile::ProfileHasPwm(o_.profile);
  if (pwm_profile_) s_.gpio.enable = s_.gpio.heartbeat = true;
}

int ScenarioRun::Validate() {
  if (const int rc = ValidateOptions(); rc != 0) return rc;
  if (const int rc = LoadProfile(); rc != 0) return rc;
  return ValidateProfileNeeds();
}

// The options and the scenario's fault list, before any profile.
int ScenarioRun::ValidateOptions() {
  const RunOptions& o = o_;
  const Scenario& s = s_;
  r_->transport = o.transport;
  r_->clock = !o.clock.empty() ? o.clock : "lockstep";
  if (s.full_car) {
    *error_ = s.path +
              ": a full car ([plant] model = \"full-car\") runs in mrd-hil study, or in mrd-hil "
              "run with [channels] (its four corners over CAN or Modbus)";
    return 2;
  }
  if (!ParseTransport(o.transport, &transport_)) {
    *error_ = "--transport '" + o.transport + "': expected can, modbus-tcp or modbus-rtu";
    return 2;
  }
  if (!ParseClock(r_->clock, &clock_)) {
    *error_ = "--clock '" + r_->clock + "': expected lockstep or realtime";
    return 2;
  }
  lockstep_ = clock_ == Clock::kLockstep;
  const bool can = transport_ == Transport::kCan;
  if (!o.can_interface.empty() && (!can || o.can_interface.find('/') != std::string::npos)) {
    *error_ = "--can-interface '" + o.can_interface +
              "': a SocketCAN interface name (no '/') "
              "with --transport can";
    return 2;
  }
  if (!o.gpio_sim.empty() && !s.gpio.any()) {
    *error_ = "--gpio-sim: scenario " + s.path + " routes nothing over GPIO (no [gpio])";
    return 2;
  }
  corrupt_table_ = std::any_of(s.faults.begin(), s.faults.end(),
                               [](const Fault& f) { return f.kind == FaultKind::kCorruptTable; });
  if (corrupt_table_ && s.faults.size() != 1) {
    *error_ = s.path + ": a corrupt_table fault runs alone (the firmware never starts)";
    return 2;
  }
  if (o.attach && std::any_of(s.faults.begin(), s.faults.end(), [](const Fault& f) {
        return f.kind == FaultKind::kKillFirmware || f.kind == FaultKind::kCorruptTable;
      })) {
    *error_ = s.path +
              ": kill_firmware and corrupt_table faults need the harness to start the "
              "firmware (drop --attach)";
    return 2;
  }
  // Corrupt frames are a CAN fault; the Modbus port plays the others on its registers
  // (ports/modbus_port.cpp).
  for (const Fault& f : s.faults) {
    if (f.kind == FaultKind::kCorrupt && !can) {
      *error_ = s.path + ":" + std::to_string(f.line) + ": fault 'corrupt' is injected on CAN " +
                "frames only (not over " + TransportName(transport_) + ")";
      return 2;
    }
  }
  return 0;
}

// The device profile: the harness plays the driver in its messages (CAN) or serves its map
// (Modbus); the firmware gets the same file.
int ScenarioRun::LoadProfile() {
  if (o_.profile.empty()) return 0;
  if (profile::IsModbusProfileFile(o_.profile)) return LoadModbusProfile();
  return LoadCanProfile();
}

int ScenarioRun::LoadModbusProfile() {
  const RunOptions& o = o_;
  if (transport_ == Transport::kCan) {
    *error_ = "--profile " + o.profile +
              ": a Modbus device profile needs --transport "
              "modbus-tcp or modbus-rtu";
    return 2;
  }
  char resolved[PATH_MAX];
  auto p = std::make_shared<profile::ModbusProfile>();
  std::string why;
  if (realpath(o.profile.c_str(), resolved) == nullptr ||
      !profile::LoadModbusProfile(resolved, p.get(), &why)) {
    *error_ = "--profile: " + (why.empty() ? o.profile + ": " + std::strerror(errno) : why);
    return 2;
  }
  if (lockstep_ && !p->In(profile::CanIn::kGrant).mapped) {
    *error_ = "--profile " + o.profile +
              ": lockstep needs a 'grant' input in the profile's "
              "[modbus.inputs] (the simulation's time grant); or --clock realtime";
    return 2;
  }
  modbus_profile_ = p;
  return 0;
}

int ScenarioRun::LoadCanProfile() {
  const RunOptions& o = o_;
  if (transport_ != Transport::kCan) {
    *error_ = "--profile: a CAN device profile needs --transport can";
    return 2;
  }
  char resolved[PATH_MAX];
  auto p = std::make_shared<profile::CanProfile>();
  std::string why;
  if (realpath(o.profile.c_str(), resolved) == nullptr ||
      !profile::LoadCanProfile(resolved, p.get(), &why)) {
    *error_ = "--profile: " + (why.empty() ? o.profile + ": " + std::strerror(errno) : why);
    return 2;
  }
  if (lockstep_ && !p->inputs[static_cast<std::size_t>(profile::CanIn::kGrant)].mapped()) {
    *error_ = "--profile " + o.profile +
              ": lockstep needs a 'grant' input in the profile (the "
              "simulation's time grant, e.g. the native TimeGrant message); or --clock realtime";
    return 2;
  }
  if (pwm_profile_ && lockstep_ &&
      !p->outputs[static_cast<std::size_t>(profile::CanOut::kStatusSafe)].mapped() &&
      !p->outputs[static_cast<std::size_t>(profile::CanOut::kStatusCauses)].mapped()) {
    *error_ = "--profile " + o.profile +
              ": lockstep with a [pwm] output needs a firmware status "
              "message in the profile (status_safe or status_causes): the harness reads each "
              "tick's duty after it; or --clock realtime";
    return 2;
  }
  can_profile_ = p;
  return 0;
}

// What the profile (or its absence) rules out: CANopen faults and hooks, --excitation.
int ScenarioRun::ValidateProfileNeeds() {
  const RunOptions& o = o_;
  const Scenario& s = s_;
  const bool canopen = can_profile_ != nullptr && can_profile_->canopen.has_value();
  for (const Fault& f : s.faults) {
    if (f.kind == FaultKind::kDriveHeartbeatLoss && !canopen) {
      *error_ = s.path + ":" + std::to_string(f.line) +
                ": fault 'drive_heartbeat_loss' needs a "
                "CANopen device profile (--profile with a [canopen] section)";
      return 2;
    }
    const std::string where = s.path + ":" + std::to_string(f.line) + ": ";
    if (f.kind == FaultKind::kFaultLine && !s.gpio.fault_line) {
      // The line on GPIO, or the fault_line input of the profile's sensor messages / registers.
      const bool mapped =
          transport_ == Transport::kCan
              ? can_profile_ != nullptr &&
                    can_profile_->inputs[static_cast<std::size_t>(profile::CanIn::kFaultLine)]
                        .mapped()
              : modbus_profile_ != nullptr &&
                    modbus_profile_->In(profile::CanIn::kFaultLine).mapped;
      if (!mapped) {
        *error_ = where +
                  "a fault_line fault needs [gpio] inputs = [..., \"fault_line\"] or a profile "
                  "mapping the fault_line input";
        return 2;
      }
    }
    if (f.kind == FaultKind::kDriverFault) {
      // CAN: the profile's (or mrd-native's) driver_faults; Modbus: the profile's, or the
      // built-in map's driver-fault bit.
      const bool can = transport_ == Transport::kCan;
      const profile::CanProfile& cp =
          can_profile_ != nullptr ? *can_profile_ : profile::NativeCanProfile();
      const bool mapped =
          can ? cp.inputs[static_cast<std::size_t>(profile::CanIn::kDriverFaults)].mapped()
              : modbus_profile_ == nullptr ||
                    modbus_profile_->In(profile::CanIn::kDriverFaults).mapped;
      if (!mapped) {
        *error_ = where +
                  "fault 'driver_fault' needs a driver that reports faults: a profile "
                  "mapping 'driver_faults' (the driver's status)";
        return 2;
      }
    }
    if (f.kind == FaultKind::kEnableRefused) {
      const profile::ModbusProfile* p = modbus_profile_.get();
      const bool apart = p != nullptr && p->Out(profile::ModbusOut::kEnable).mapped &&
                         p->Out(profile::ModbusOut::kEnable).request !=
                             p->Out(profile::ModbusOut::kCommand).request;
      if (!apart) {
        *error_ = where +
                  "fault 'enable_refused' needs a Modbus device profile whose 'enable' "
                  "is written apart from its 'command' (--profile with a [modbus] section)";
        return 2;
      }
    }
  }
  if (!o.sdo_refuse.empty() && (!canopen || !ParseSdoRefusal(o.sdo_refuse, &refusal_))) {
    *error_ = "--sdo-refuse '" + o.sdo_refuse + "': " +
              (canopen ? "expected INDEX[:SUBINDEX]=ABORT_CODE (e.g. 0x6060=0x06090030)"
                       : "needs a CANopen device profile (--profile with a [canopen] section)");
    return 2;
  }
  if (s.quarter_car && !o.excitation.empty()) {
    *error_ = "--excitation: " + s.path + " is a quarter car, excited by its [road]";
    return 2;
  }
  if (s.structure && !o.excitation.empty()) {
    *error_ = "--excitation: " + s.path + " is a structure, excited by its [structure] record";
    return 2;
  }
  return 0;
}

}  // namespace mrd::hil
