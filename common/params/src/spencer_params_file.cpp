#include "mrd/params/spencer_params_file.hpp"

#include <toml++/toml.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>

#include "mrd/common/input_file.hpp"

namespace mrd::params {

void SpencerFields(SpencerParams* p, SpencerField (&out)[kSpencerFieldCount]) {
  const SpencerField f[kSpencerFieldCount] = {
      {"c0a", &p->c0a},     {"c0b", &p->c0b},         {"k0", &p->k0},
      {"c1a", &p->c1a},     {"c1b", &p->c1b},         {"k1", &p->k1},
      {"x0", &p->x0},       {"alpha_a", &p->alpha_a}, {"alpha_b", &p->alpha_b},
      {"gamma", &p->gamma}, {"beta", &p->beta},       {"A", &p->A},
      {"n", &p->n},         {"eta", &p->eta}};
  for (std::size_t i = 0; i < kSpencerFieldCount; ++i) out[i] = f[i];
}

bool SetSpencerField(SpencerParams* p, const std::string& key, double value) {
  SpencerField f[kSpencerFieldCount];
  SpencerFields(p, f);
  for (const SpencerField& x : f) {
    if (key == x.key) {
      *x.value = value;
      return true;
    }
  }
  return false;
}

namespace {
std::string Num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}
}  // namespace

bool CheckPhysical(const SpencerParams& p, std::string* why) {
  struct Rule {
    const char* key;
    double v;
    double lo;
    bool open;  // lo excluded
    double hi;
  };
  constexpr double kInf = HUGE_VAL;
  const Rule rules[] = {{"c0a", p.c0a, 0, true, kInf},
                        {"c0b", p.c0b, 0, false, kInf},
                        {"k0", p.k0, 0, true, kInf},
                        {"c1a", p.c1a, 0, true, kInf},
                        {"c1b", p.c1b, 0, false, kInf},
                        {"k1", p.k1, 0, false, kInf},
                        {"x0", p.x0, -kInf, false, kInf},
                        {"alpha_a", p.alpha_a, 0, false, kInf},
                        {"alpha_b", p.alpha_b, 0, false, kInf},
                        {"gamma", p.gamma, 0, false, kInf},
                        {"beta", p.beta, -kInf, false, kInf},
                        {"A", p.A, 0, false, kInf},
                        {"n", p.n, 1, false, 10},
                        {"eta", p.eta, 0, true, kInf}};
  for (const Rule& r : rules) {
    if (!std::isfinite(r.v)) {
      *why = std::string("invalid parameter '") + r.key + "': must be finite";
      return false;
    }
    const bool low = r.open ? !(r.v > r.lo) : !(r.v >= r.lo);
    if (low || r.v > r.hi) {
      std::string range = std::isinf(r.hi) ? (r.open ? "> " : ">= ") + Num(r.lo)
                                           : "in [" + Num(r.lo) + ", " + Num(r.hi) + "]";
      *why = std::string("invalid parameter '") + r.key + "': must be " + range + " (is " +
             Num(r.v) + "), not a physical damper";
      return false;
    }
  }
  return true;
}

bool LoadSpencerParamsFile(const std::string& path, SpencerParams* out, ParamsError* error) {
  // A regular file of at most 1 MiB (a directory, FIFO or device is refused, not parsed).
  std::string text, refusal;
  if (!ReadInputFileOrWhy(path, std::uint64_t{1} << 20, &text, &refusal)) {
    *error = {0, refusal};  // the caller names the file
    return false;
  }
  toml::table tbl;
  try {
    tbl = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    *error = {e.source().begin.line, std::string(e.description())};
    return false;
  }
  SpencerParams p;
  std::size_t preset_line = 0;
  if (auto preset = tbl["preset"]) {
    preset_line = preset.node()->source().begin.line;
    const auto name = preset.value_exact<std::string>();
    if (!name) {
      *error = {preset_line, "preset must be a string"};
      return false;
    }
    if (!SpencerParams::FromPreset(*name, &p)) {
      *error = {preset_line, "unknown preset '" + *name + "' (expected paper or spencer1997)"};
      return false;
    }
  }
  SpencerField fields[kSpencerFieldCount];
  SpencerFields(&p, fields);
  for (const auto& [key, node] : tbl) {
    if (key == "preset") continue;
    const std::size_t line = node.source().begin.line;
    const SpencerField* field = nullptr;
    for (const SpencerField& f : fields) {
      if (key.str() == f.key) field = &f;
    }
    if (field == nullptr) {
      std::string why = "unknown key '";  // appended piecewise: GCC 12 -Wrestrict
      why.append(key.str()).append(
          "' (expected preset or one of c0a c0b k0 c1a c1b k1 x0 "
          "alpha_a alpha_b gamma beta A n eta)");
      *error = {line, why};
      return false;
    }
    const auto v = node.value<double>();  // integers too
    if (!v || node.is_boolean()) {
      std::string why = "'";
      why.append(key.str()).append("' must be a number");
      *error = {line, why};
      return false;
    }
    *field->value = *v;
    SpencerParams single = SpencerParams::Paper();
    std::string why;
    SetSpencerField(&single, field->key, *v);
    if (!CheckPhysical(single, &why)) {
      *error = {line, why};
      return false;
    }
  }
  std::string why;
  if (!CheckPhysical(p, &why)) {
    *error = {preset_line, why};
    return false;
  }
  *out = p;
  return true;
}

std::string SpencerParamsText(const SpencerParams& p, const std::string& header) {
  std::ostringstream o;
  std::istringstream h(header);
  for (std::string line; std::getline(h, line);) o << "# " << line << "\n";
  SpencerParams copy = p;
  SpencerField fields[kSpencerFieldCount];
  SpencerFields(&copy, fields);
  for (const SpencerField& f : fields) o << f.key << " = " << Num(*f.value) << "\n";
  return o.str();
}

}  // namespace mrd::params
