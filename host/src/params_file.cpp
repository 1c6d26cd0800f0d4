#include "mrd/host/params_file.hpp"

#include <fmt/format.h>

#include <toml++/toml.h>

#include "mrd/host/input_error.hpp"

namespace mrd::host {

SpencerParams SpencerPreset(const std::string& name) {
  SpencerParams p;
  if (!SpencerParams::FromPreset(name, &p)) {
    throw InputError("", 0,
                     fmt::format("unknown preset '{}' (expected paper or spencer1997)", name));
  }
  return p;
}

SpencerParams LoadSpencerParams(const std::string& path) {
  toml::table tbl;
  try {
    tbl = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw InputError(path, e.source().begin.line, std::string(e.description()));
  }
  SpencerParams p;
  if (auto preset = tbl["preset"]) {
    const auto name = preset.value<std::string>();
    if (!name) throw InputError(path, preset.node()->source().begin.line, "preset must be a string");
    SpencerParams base;
    if (!SpencerParams::FromPreset(*name, &base)) {
      throw InputError(path, preset.node()->source().begin.line,
                       fmt::format("unknown preset '{}'", *name));
    }
    p = base;
  }
  struct Field {
    const char* key;
    double* value;
  };
  const Field fields[] = {{"c0a", &p.c0a},         {"c0b", &p.c0b},     {"k0", &p.k0},
                          {"c1a", &p.c1a},         {"c1b", &p.c1b},     {"k1", &p.k1},
                          {"x0", &p.x0},           {"alpha_a", &p.alpha_a},
                          {"alpha_b", &p.alpha_b}, {"gamma", &p.gamma}, {"beta", &p.beta},
                          {"A", &p.A},             {"n", &p.n},         {"eta", &p.eta}};
  for (const auto& [key, node] : tbl) {
    if (key == "preset") continue;
    const Field* field = nullptr;
    for (const Field& f : fields) {
      if (key == f.key) field = &f;
    }
    const auto line = node.source().begin.line;
    if (field == nullptr) throw InputError(path, line, fmt::format("unknown key '{}'", key.str()));
    const auto v = node.value<double>();  // accepts integers too
    if (!v) throw InputError(path, line, fmt::format("'{}' must be a number", key.str()));
    *field->value = *v;
  }
  const char* reason = nullptr;
  if (!p.IsValid(&reason)) {
    throw InputError(path, 0,
                     fmt::format("invalid parameter '{}': must be finite (c0a, c1a, k0, n and "
                                 "eta also positive)",
                                 reason));
  }
  return p;
}

}  // namespace mrd::host
