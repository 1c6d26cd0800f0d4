#include "scenario_set.hpp"

#include <utility>

#include "mrd/common/input_file.hpp"

namespace mrd::hil {
namespace {

bool BareKey(const std::string& k) {
  if (k.empty()) return false;
  for (const char ch : k) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') ||
                    (ch >= '0' && ch <= '9') || ch == '_' || ch == '-';
    if (!ok) return false;
  }
  return true;
}

// A TOML basic string holding text (quotes, backslashes and control characters escaped).
std::string Quoted(const std::string& text) {
  std::string q = "\"";
  for (const unsigned char ch : text) {
    if (ch == '"' || ch == '\\') {
      q += '\\';
      q += static_cast<char>(ch);
    } else if (ch < 0x20 || ch == 0x7f) {
      static const char* hex = "0123456789ABCDEF";
      q += "\\u00";
      q += hex[ch >> 4];
      q += hex[ch & 15];
    } else {
      q += static_cast<char>(ch);
    }
  }
  return q + "\"";
}

// src into dst: tables merge key by key, anything else replaces what dst had.
void Merge(toml::table&& src, toml::table& dst) {
  for (auto&& [k, v] : src) {
    toml::table* d = dst.get_as<toml::table>(k.str());
    toml::table* s = v.as_table();
    if (d != nullptr && s != nullptr) {
      Merge(std::move(*s), *d);
    } else {
      dst.insert_or_assign(k, std::move(v));
    }
  }
}

}  // namespace

bool ApplyScenarioSets(const std::vector<std::string>& sets, toml::table* root,
                       std::string* error) {
  for (const std::string& spec : sets) {
    const std::string label = "--set " + Printable(spec);
    const auto eq = spec.find('=');
    if (eq == std::string::npos) {
      *error = label + ": expected KEY=VALUE (e.g. control.skyhook_gain=40)";
      return false;
    }
    const std::string key = spec.substr(0, eq), value = spec.substr(eq + 1);
    std::size_t from = 0;
    while (true) {
      const auto dot = key.find('.', from);
      const std::string part = key.substr(from, dot == std::string::npos ? dot : dot - from);
      if (!BareKey(part)) {
        *error = label +
                 ": KEY must be a dotted path of names (letters, digits, _ and -), "
                 "e.g. control.skyhook_gain";
        return false;
      }
      if (dot == std::string::npos) break;
      from = dot + 1;
    }
    if (value.empty()) {
      *error = label + ": no VALUE after '='";
      return false;
    }
    bool control = false;  // a line break would let VALUE add keys of its own: a string then
    for (const unsigned char ch : value) control = control || ch < 0x20 || ch == 0x7f;
    toml::table parsed;
    bool typed = false;
    if (!control) {
      try {
        parsed = toml::parse(key + " = " + value, label);
        typed = true;
      } catch (const toml::parse_error&) {
      }
    }
    if (!typed) {
      try {
        parsed = toml::parse(key + " = " + Quoted(value), label);  // a bare word: a string
      } catch (const toml::parse_error& e) {
        *error = label + ": " + Printable(e.description());
        return false;
      }
    }
    Merge(std::move(parsed), *root);
  }
  return true;
}

}  // namespace mrd::hil
