// [channels]: a full car's four corners on one firmware over CAN or Modbus
// (scenario_reader.hpp).
#include <cstdlib>
#include <filesystem>

#include "mrd/common/file_path.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "scenario_reader.hpp"

namespace mrd::hil::scenario_reader {
namespace {

// A list of file names into *out, as given.
Setter FileNames(const char* key, std::vector<std::string>* out) {
  return [key, out](const toml::node& n, Ctx& c) {
    const toml::array* a = n.as_array();
    if (a == nullptr) return c.Fail(n, std::string("'") + key + "' must be a list of 4 file names");
    out->clear();
    for (const toml::node& e : *a) {
      const auto v = e.value_exact<std::string>();
      if (!v || v->empty()) return c.Fail(e, std::string("'") + key + "' takes file names");
      out->push_back(*v);
    }
    return true;
  };
}

}  // namespace

std::map<std::string, Setter> ScenarioReader::ChannelsKeys() {
  ScenarioChannels& ch = s.channels;
  return {{"can_profiles", FileNames("can_profiles", &channel_profiles_)},
          {"modbus_profiles", FileNames("modbus_profiles", &channel_maps_)},
          {"fault_policy", Str(&ch.fault_policy, "fault_policy")},
          {"body_law", Str(&ch.body_law, "body_law")},
          {"heave_n_s_per_m", Num(&heave_, 0.0, 1e9, "heave_n_s_per_m")},
          {"pitch_n_m_s_per_rad", Num(&pitch_, 0.0, 1e9, "pitch_n_m_s_per_rad")},
          {"roll_n_m_s_per_rad", Num(&roll_, 0.0, 1e9, "roll_n_m_s_per_rad")}};
}

// A full car, four readable profiles (absolute: the generated firmware configuration names
// them from the run's folder), a known policy and body law, a law each corner can run on its
// own signals, and faults the corners' sensors and drives can take.
bool ScenarioReader::CheckChannels() {
  Ctx& c = c_;
  ScenarioChannels& ch = s.channels;
  const bool corner_fault = [&] {
    for (const Fault& f : s.faults) {
      if (f.corner >= 0) return true;
    }
    return false;
  }();
  if (!root_.contains("channels")) {
    if (corner_fault) return c.Fail(at("fault"), "a fault's 'corner' needs [channels]");
    return true;
  }
  if (!s.full_car) return c.Fail(at("channels"), "[channels] needs [plant] model = \"full-car\"");
  if (!channel_profiles_.empty() && !channel_maps_.empty()) {
    return c.Fail(at("channels.modbus_profiles"),
                  "[channels] takes can_profiles (four corners over CAN) or modbus_profiles "
                  "(over one Modbus link), not both");
  }
  const bool modbus = !channel_maps_.empty();
  const char* key = modbus ? "modbus_profiles" : "can_profiles";
  const std::vector<std::string>& given = modbus ? channel_maps_ : channel_profiles_;
  if (given.size() != 4) {
    return c.Fail(at("channels"), std::string("[channels] ") + key + " must name 4 " +
                                      (modbus ? "Modbus register maps" : "CAN device profiles") +
                                      " (front-left, front-right, rear-left, rear-right)");
  }
  for (const std::string& name : given) {
    const std::string file = ResolveBeside(path_, name);
    const std::string where = std::string("channels.") + key;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
      return c.Fail(at(where.c_str()), std::string(key) + ": '" + file + "': not a file");
    }
    // The profile's kind is the transport's: a [modbus] map over Modbus, a CAN profile on CAN.
    if (profile::IsModbusProfileFile(file) != modbus) {
      return c.Fail(at(where.c_str()),
                    std::string(key) + ": '" + file + "': " +
                        (modbus ? "not a Modbus device profile (no [modbus] section); "
                                  "CAN profiles go in can_profiles"
                                : "a Modbus device profile; Modbus maps go in "
                                  "modbus_profiles"));
    }
    (modbus ? ch.modbus_profiles : ch.can_profiles)
        .push_back(std::filesystem::absolute(file, ec).lexically_normal().string());
  }
  if (ch.fault_policy != "all" && ch.fault_policy != "channel") {
    return c.Fail(at("channels.fault_policy"), "fault_policy must be \"all\" or \"channel\"");
  }
  if (ch.body_law != "none" && ch.body_law != "modal-skyhook") {
    return c.Fail(at("channels.body_law"), "body_law must be \"none\" or \"modal-skyhook\"");
  }
  if (heave_ >= 0.0) ch.heave_n_s_per_m = heave_;
  if (pitch_ >= 0.0) ch.pitch_n_m_s_per_rad = pitch_;
  if (roll_ >= 0.0) ch.roll_n_m_s_per_rad = roll_;
  const bool modal = ch.body_law == "modal-skyhook";
  if ((heave_ >= 0.0 || pitch_ >= 0.0 || roll_ >= 0.0) && !modal) {
    return c.Fail(at("channels"),
                  "the heave, pitch and roll gains need body_law = \"modal-skyhook\"");
  }
  if (modal ? s.law != "force"
            : s.law != "skyhook" && s.law != "passive-off" && s.law != "passive-on" &&
                  s.law != "constant") {
    return c.Fail(at(has("control.law") ? "control.law" : "channels"),
                  modal ? "body_law = \"modal-skyhook\" needs [control] law = \"force\" (the body "
                          "law sets each corner's demand)"
                        : "four corners run law skyhook, passive-off, passive-on or constant (or "
                          "body_law = \"modal-skyhook\" with law \"force\")");
  }
  for (const Fault& f : s.faults) {
    const bool ok = f.kind == FaultKind::kDrop || f.kind == FaultKind::kCorrupt ||
                    f.kind == FaultKind::kStall || f.kind == FaultKind::kOutOfRange ||
                    f.kind == FaultKind::kNan || f.kind == FaultKind::kDriveHeartbeatLoss ||
                    f.kind == FaultKind::kDriverFault;
    if (!ok) {
      *error_ = path_ + ":" + std::to_string(f.line) + ": fault kind '" + FaultKindName(f.kind) +
                "' is not played on four corners (drop, corrupt, stall, out_of_range, nan, "
                "drive_heartbeat_loss, driver_fault are)";
      return false;
    }
    // Corrupt frames and a CANopen drive's heartbeat are CAN's (the Modbus maps' registers
    // take the others).
    if (modbus && (f.kind == FaultKind::kCorrupt || f.kind == FaultKind::kDriveHeartbeatLoss)) {
      *error_ = path_ + ":" + std::to_string(f.line) + ": fault kind '" + FaultKindName(f.kind) +
                "' is played on CAN only (modbus_profiles: drop, stall, out_of_range, nan, "
                "driver_fault are)";
      return false;
    }
  }
  return true;
}

}  // namespace mrd::hil::scenario_reader
