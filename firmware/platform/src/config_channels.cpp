// The [channels] section (channels_config.hpp): its list key and its checks against the rest
// of the configuration. Compiled with exceptions (toml++); the callers catch everything.
#include <string>
#include <vector>

#include "config_parts.hpp"
#include "mrd/common/file_path.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/firmware/platform/table_file.hpp"

namespace mrd::firmware::platform::config_detail {

Key FileList(const char* name, std::vector<std::string>* out, const char* none_shown,
             const char* description) {
  Setter set = [out](const toml::node& n, std::string* why) {
    const toml::array* a = n.as_array();
    if (a == nullptr || a->empty() || a->size() > kMaxChannels) {
      return *why = "must be a list of 1 to " + std::to_string(kMaxChannels) + " file names", false;
    }
    std::vector<std::string> names;
    for (const toml::node& e : *a) {
      const auto v = e.value_exact<std::string>();
      if (!v || v->empty() || v->size() > 4096) {
        return *why = "must hold file names (non-empty strings of at most 4096 bytes)", false;
      }
      names.push_back(*v);
    }
    *out = names;
    return true;
  };
  auto show = [out, none_shown] {
    if (out->empty()) {
      std::string none = "(";
      none.append(none_shown).push_back(')');
      return none;
    }
    std::string list;
    for (const std::string& t : *out) list += (list.empty() ? "\"" : ", \"") + t + "\"";
    return "[" + list + "]";
  };
  return {name, set, show, "a list of file names, one per channel", "", description, "list"};
}

Key GeometryKey(Key number, std::uint32_t* given, std::uint32_t bit) {
  number.set = [given, bit, inner = number.set](const toml::node& n, std::string* why) {
    if (!inner(n, why)) return false;
    *given |= bit;
    return true;
  };
  number.show = [given, bit, shown = number.show] {
    return (*given & bit) != 0 ? shown() : std::string("(required by modal-skyhook)");
  };
  return number;
}

namespace {

// "SOURCE:LINE: [channels] " + why at key (or the section).
bool Refuse(const toml::table& root, const std::string& source, const char* key,
            const std::string& why, std::string* error) {
  *error = Where(root, source, "channels", key) + "[channels] " + why;
  return false;
}

bool CheckBodyLaw(const toml::table& root, const std::string& source, const FirmwareConfig& c,
                  std::string* error) {
  const ChannelsConfig& ch = c.channels;
  if (ch.body_law == BodyLawKind::kNone) {
    if (ch.geometry_given != 0) {
      return Refuse(root, source, "body_law",
                    "the body geometry is given but body_law is \"none\" (the geometry serves "
                    "body_law = \"modal-skyhook\")",
                    error);
    }
    return true;
  }
  if (ch.count != kModalCorners) {
    return Refuse(root, source, "body_law",
                  "body_law = \"modal-skyhook\" needs count = 4 (front-left, front-right, "
                  "rear-left, rear-right); count is " +
                      std::to_string(ch.count),
                  error);
  }
  if (ch.geometry_given != ChannelsConfig::kAllGeometry) {
    return Refuse(root, source, "body_law",
                  "body_law = \"modal-skyhook\" needs the body geometry: cg_to_front_m, "
                  "cg_to_rear_m, track_front_m, track_rear_m and motion_ratio",
                  error);
  }
  if (c.controller.law.mode != ControlMode::kForceTracking) {
    return Refuse(root, source, "body_law",
                  "body_law = \"modal-skyhook\" sets force demands: it needs [control] law = "
                  "\"force\"",
                  error);
  }
  ModalSkyhook law;
  const char* reason = "out of range";
  if (law.Configure(ch.geometry, ch.gains, &reason) != Error::kOk) {
    return Refuse(root, source, "body_law", std::string("modal skyhook: ") + reason, error);
  }
  return true;
}

// Each table file named loads (once per distinct name); its resolved path per channel.
bool LoadTables(const toml::table& root, const std::string& source, ChannelsConfig* ch,
                std::string* error) {
  ch->table_paths.clear();
  for (std::size_t i = 0; i < ch->tables.size(); ++i) {
    const std::string path = ResolveBeside(source, ch->tables[i]);
    bool seen = false;
    for (const std::string& p : ch->table_paths) seen = seen || p == path;
    ch->table_paths.push_back(path);
    if (seen) continue;
    std::string reason;
    if (!LoadTableFile(path.c_str(), &reason).ok()) {
      return Refuse(root, source, "tables",
                    "tables: channel " + std::to_string(i) + "'s table '" +
                        Printable(ch->tables[i]) + "': " + Printable(reason),
                    error);
    }
  }
  return true;
}

// One bus's per-channel profile list ([channels] can_profiles or modbus_profiles).
struct ProfileList {
  const char* key;      // "can_profiles"
  const char* section;  // "can"
  const char* bus;      // "CAN bus"
  const std::vector<std::string>* files;
  bool section_given;       // [section] is in the file
  bool no_section_profile;  // [section] names no profile of its own
};

// The list against count and its bus section; count > 1 with the section needs the list.
bool CheckProfileList(const toml::table& root, const std::string& source, const FirmwareConfig* c,
                      const ProfileList& l, std::string* error) {
  const ChannelsConfig& ch = c->channels;
  const std::string key = l.key, section = l.section;
  if (l.files->empty()) {
    if (ch.count > 1 && l.section_given) {
      return Refuse(root, source, "count",
                    "count " + std::to_string(ch.count) + " with [" + section +
                        "]: several channels need one device profile each; give [channels] " + key +
                        " = [\"corner-0.toml\", ...] (" + std::to_string(ch.count) +
                        " entries) or set count = 1",
                    error);
    }
    return true;
  }
  if (l.files->size() != static_cast<std::size_t>(ch.count)) {
    return Refuse(root, source, l.key,
                  key + " names " + std::to_string(l.files->size()) +
                      " device profiles; count is " + std::to_string(ch.count) +
                      " (one per channel)",
                  error);
  }
  if (!l.section_given) {
    return Refuse(root, source, l.key,
                  key + " needs a [" + section + "] section (the " + l.bus + " the channels share)",
                  error);
  }
  if (!l.no_section_profile) {
    *error = Where(root, source, l.section, "profile") + "[" + section +
             "] profile and [channels] " + key + " are both given: with " + key +
             " each channel has its own device profile; remove [" + section + "] profile";
    return false;
  }
  return true;
}

}  // namespace

bool CheckChannels(const toml::table& root, const std::string& source, FirmwareConfig* c,
                   std::string* error) {
  ChannelsConfig& ch = c->channels;
  const std::string count = "count " + std::to_string(ch.count);
  if (ch.count > 1 && (c->io.gpio.enabled || c->io.pwm.enabled)) {
    return Refuse(root, source, "count",
                  count +
                      ": several channels run over [can] (can_profiles), over [modbus] "
                      "(modbus_profiles) or on the simulated dampers of --dry-run in this "
                      "version; [gpio] and [pwm] serve one channel only: remove them or set "
                      "count = 1",
                  error);
  }
  if (!ch.can_profiles.empty() && !ch.modbus_profiles.empty()) {
    return Refuse(root, source, "modbus_profiles",
                  "can_profiles and modbus_profiles are both given: the channels share one bus "
                  "in this version ([can] with can_profiles, or [modbus] with modbus_profiles)",
                  error);
  }
  // One bus for several channels: the other bus section would serve channel 0 alone.
  if (ch.count > 1 && c->io.can.enabled && c->io.modbus.enabled) {
    return Refuse(root, source, "count",
                  count +
                      ": [can] and [modbus] are both given; several channels share one bus in "
                      "this version: remove one of them or set count = 1",
                  error);
  }
  if (!CheckProfileList(root, source, c,
                        {"can_profiles", "can", "CAN bus", &ch.can_profiles, c->io.can.enabled,
                         c->io.can.profile.empty()},
                        error) ||
      !CheckProfileList(root, source, c,
                        {"modbus_profiles", "modbus", "Modbus link", &ch.modbus_profiles,
                         c->io.modbus.enabled, c->io.modbus.profile.empty()},
                        error)) {
    return false;
  }
  if (ch.count > 1 && root.contains("ctl")) {
    return Refuse(root, source, "count",
                  "count " + std::to_string(ch.count) +
                      ": the runtime parameters ([ctl], mrd-firmware ctl) serve one channel "
                      "only in this version; remove [ctl] or set count = 1",
                  error);
  }
  if (!ch.tables.empty() && ch.tables.size() != static_cast<std::size_t>(ch.count)) {
    return Refuse(root, source, "tables",
                  "tables names " + std::to_string(ch.tables.size()) + " tables; count is " +
                      std::to_string(ch.count) +
                      " (one per channel; a table may be named several times)",
                  error);
  }
  if (!CheckBodyLaw(root, source, *c, error)) return false;
  return LoadTables(root, source, &ch, error);
}

}  // namespace mrd::firmware::platform::config_detail
