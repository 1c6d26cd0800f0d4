// Runtime parameters over the key table (config.hpp): list, set one, and the keys a reload may
// not change. Compiled with exceptions (toml++); every function catches everything.
#include <cstring>

#include "config_parts.hpp"
#include "mrd/common/input_file.hpp"

namespace mrd::firmware::platform {

using config_detail::CheckIo;
using config_detail::Key;
using config_detail::KeyTable;
using config_detail::Scratch;
using config_detail::Sections;
using config_detail::Show;

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

}  // namespace mrd::firmware::platform
