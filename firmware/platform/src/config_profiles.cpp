// The device profiles the bus sections name, loaded relative to the configuration file and
// checked against the routing (config_parts.hpp).
#include <memory>

#include "config_parts.hpp"
#include "mrd/common/file_path.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/firmware/io/input_roles.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_channels.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/profile/pwm_profile.hpp"

namespace mrd::firmware::platform::config_detail {

// [can] profile: loaded (relative to the configuration file) and checked against the routing:
// every input and output the [can] section names, and the grant in lockstep, must be a role
// the profile maps. Without the key: the built-in mrd-native profile (checked the same way).
namespace {

// Profile p against the [can] routing of c; where: "SOURCE:LINE: " to blame.
bool CheckCanRouting(const profile::CanProfile* p, const std::string& where,
                     const FirmwareConfig* c, std::string* error) {
  const CanConfig& can = c->io.can;
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

// The profile file (relative to the configuration file), loaded; where: "SOURCE:LINE: ".
std::shared_ptr<const profile::CanProfile> LoadCanFile(const std::string& source,
                                                       const std::string& file,
                                                       const std::string& where,
                                                       std::string* error) {
  auto loaded = std::make_shared<profile::CanProfile>();
  std::string why;
  if (!profile::LoadCanProfile(ResolveBeside(source, file), loaded.get(), &why)) {
    *error = where + "device profile: " + Printable(why);
    return nullptr;
  }
  return loaded;
}

}  // namespace

bool LoadCanProfileOf(const toml::table& root, const std::string& source, FirmwareConfig* c,
                      std::string* error) {
  CanConfig& can = c->io.can;
  ChannelsConfig& ch = c->channels;
  ch.can_device_profiles.clear();
  // Several channels: each one's profile (CheckChannels: count entries, no [can] profile).
  for (std::size_t i = 0; i < ch.can_profiles.size(); ++i) {
    const std::string where = Where(root, source, "channels", "can_profiles") +
                              "[channels] can_profiles: channel " + std::to_string(i) + " (" +
                              Printable(ch.can_profiles[i]) + "): ";
    auto p = LoadCanFile(source, ch.can_profiles[i], where, error);
    if (p == nullptr || !CheckCanRouting(p.get(), where, c, error)) return false;
    ch.can_device_profiles.push_back(p);
  }
  if (!ch.can_device_profiles.empty()) {
    can.can_profile = ch.can_device_profiles[0];  // the single-device paths' view
    return true;
  }
  if (can.profile.empty()) {
    return CheckCanRouting(&profile::NativeCanProfile(), Where(root, source, "can", "inputs"), c,
                           error);
  }
  const std::string where = Where(root, source, "can", "profile");
  auto p = LoadCanFile(source, can.profile, where, error);
  if (p == nullptr || !CheckCanRouting(p.get(), where, c, error)) return false;
  can.can_profile = p;
  return true;
}

// [modbus] profile: loaded (relative to the configuration file) and checked against the
// routing: every input and output the [modbus] section names, and the grant in lockstep
// (grants on Modbus: no [can] bus), must be a role the profile maps. fault_line is served by
// the profile's fault_line or driver_faults role.
namespace {

// Profile p against the [modbus] routing of c; where: "SOURCE:LINE: " to blame; grant: the
// lockstep grant must be mapped (the one profile, or channel 0's).
bool CheckModbusRouting(const profile::ModbusProfile& p, const std::string& where,
                        const FirmwareConfig* c, bool grant, std::string* error) {
  const ModbusConfig& mb = c->io.modbus;
  const auto in = [&](profile::CanIn r) { return p.In(r).mapped; };
  const auto out = [&](profile::ModbusOut r) { return p.Out(r).mapped; };
  for (const InputRole& m : kInputRoles) {
    const bool mapped =
        in(m.role) || (m.role == profile::CanIn::kFaultLine && in(profile::CanIn::kDriverFaults));
    if ((mb.inputs & Bit(m.input)) != 0 && !mapped) {
      *error = where + "profile " + p.name + " maps no register to input '" + InputName(m.input) +
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
      *error = where + "profile " + p.name + " maps no register to output '" + OutputName(output) +
               "' ([modbus.outputs] of the profile)";
      return false;
    }
  }
  if (grant && c->clock == LoopClock::kGrant && !c->io.can.enabled && !in(profile::CanIn::kGrant)) {
    *error = where + "clock = \"grant\" needs the profile's 'grant' input (profile " + p.name +
             " has none)";
    return false;
  }
  return true;
}

// The map file (relative to the configuration file), loaded; where: "SOURCE:LINE: ".
std::shared_ptr<const profile::ModbusProfile> LoadModbusFile(const std::string& source,
                                                             const std::string& file,
                                                             const std::string& where,
                                                             std::string* error) {
  auto p = std::make_shared<profile::ModbusProfile>();
  std::string why;
  if (!profile::LoadModbusProfile(ResolveBeside(source, file), p.get(), &why)) {
    *error = where + "device profile: " + Printable(why);
    return nullptr;
  }
  return p;
}

// Several channels: each one's map ([channels] modbus_profiles; CheckChannels: count entries,
// no [modbus] profile), checked against the routing and planned on the one link.
bool LoadModbusChannelMaps(const toml::table& root, const std::string& source, FirmwareConfig* c,
                           std::string* error) {
  ChannelsConfig& ch = c->channels;
  const std::string at = Where(root, source, "channels", "modbus_profiles");
  std::vector<const profile::ModbusProfile*> maps;
  for (std::size_t i = 0; i < ch.modbus_profiles.size(); ++i) {
    const std::string where = at + "[channels] modbus_profiles: channel " + std::to_string(i) +
                              " (" + Printable(ch.modbus_profiles[i]) + "): ";
    auto p = LoadModbusFile(source, ch.modbus_profiles[i], where, error);
    if (p == nullptr || !CheckModbusRouting(*p, where, c, i == 0, error)) return false;
    ch.modbus_device_profiles.push_back(p);
    maps.push_back(p.get());
  }
  profile::ModbusChannelPlan plan;
  std::string why;
  if (!profile::PlanModbusChannels(maps, &plan, &why)) {
    *error = at + "[channels] modbus_profiles: the maps cannot share one link: " + Printable(why);
    return false;
  }
  return true;
}

}  // namespace

bool LoadModbusProfileOf(const toml::table& root, const std::string& source, FirmwareConfig* c,
                         std::string* error) {
  ModbusConfig& mb = c->io.modbus;
  c->channels.modbus_device_profiles.clear();
  if (!c->channels.modbus_profiles.empty()) return LoadModbusChannelMaps(root, source, c, error);
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
  auto p = LoadModbusFile(source, mb.profile, where, error);
  if (p == nullptr || !CheckModbusRouting(*p, where, c, true, error)) return false;
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

}  // namespace mrd::firmware::platform::config_detail
