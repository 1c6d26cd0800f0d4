// Loading the PWM part of a device profile (pwm_profile.hpp). toml++ reports errors by
// exception: this file is compiled with exceptions and catches them all.
#include "mrd/profile/pwm_profile.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>

#include "command_section.hpp"
#include "file_text.hpp"
#include "profile_context.hpp"

namespace mrd::profile {
namespace {

bool Fraction(const ProfileContext& c, const toml::node& v, const std::string& key, double* out) {
  const auto d = v.value<double>();
  if (!d || !std::isfinite(*d) || *d < 0.0 || *d > 1.0) {
    return c.Fail(&v, key + ": expected a duty fraction in [0, 1]");
  }
  *out = *d;
  return true;
}

bool Pwm(const ProfileContext& c, const toml::table& t, PwmProfile* p) {
  for (const auto& [k, v] : t) {
    const std::string key(k.str());
    const std::string full = "pwm." + key;
    if (key == "period_ns") {
      const auto n = v.value_exact<std::int64_t>();
      if (!n || *n < 1000 || *n > 1'000'000'000) {
        return c.Fail(&v, full + ": expected an integer number of ns in 1000 .. 1000000000");
      }
      p->period_ns = *n;
    } else if (key == "polarity") {
      const auto s = v.value_exact<std::string>();
      if (s && *s == "normal") {
        p->inversed = false;
      } else if (s && *s == "inversed") {
        p->inversed = true;
      } else {
        return c.Fail(&v, full + ": expected \"normal\" or \"inversed\"");
      }
    } else if (key == "min_duty") {
      if (!Fraction(c, v, full, &p->min_duty)) return false;
    } else if (key == "max_duty") {
      if (!Fraction(c, v, full, &p->max_duty)) return false;
    } else {
      return c.Fail(&v, full + ": unknown key (period_ns, polarity, min_duty, max_duty)");
    }
  }
  if (!(p->min_duty < p->max_duty)) {
    return c.Fail(&t, "pwm: min_duty must be below max_duty");
  }
  return true;
}

// [command] as can_profile.cpp reads it, with min and max required: they are the driver's
// input range the duty range stands for.
bool Command(const ProfileContext& c, const toml::node* node, const std::string& dir,
             PwmProfile* p) {
  const toml::table* t = node != nullptr ? node->as_table() : nullptr;
  if (t == nullptr) {
    return c.Fail(node,
                  "command: a [pwm] profile needs a [command] table with min and max (the "
                  "driver's input range that min_duty..max_duty stands for)");
  }
  CommandSection cmd{p->command_unit, NAN, NAN, 0.0};
  const toml::node* bad = nullptr;
  std::string reason;
  if (!ReadCommandSection(*t, dir, &cmd, &p->command, &bad, &reason)) {
    return c.Fail(bad, reason);
  }
  p->command_unit = cmd.unit;
  const double min = cmd.min, max = cmd.max, slew = cmd.slew_per_s;
  if (std::isnan(min) || std::isnan(max)) {
    return c.Fail(t, "command: a [pwm] profile needs min and max (the driver's input range)");
  }
  std::string why;
  if (!p->command.SetRange(min, max, slew, &why)) return c.Fail(t, why);
  // The duty carries [min, max] (min_duty..max_duty); the safe state must be its off.
  SetpointCarrier carrier{"the PWM duty (min_duty..max_duty)", min, max, 0.0};
  const char* key = nullptr;
  why = CheckCommandCarrier(p->command, p->command_unit, carrier, &key);
  if (!why.empty()) return c.Fail(t, why);
  return true;
}

}  // namespace

double PwmProfile::SetpointToDuty(double u) const {
  const double lo = command.min(), hi = command.max();
  double t = (u - lo) / (hi - lo);
  if (!std::isfinite(t) || t < 0.0) t = 0.0;
  if (t > 1.0) t = 1.0;
  return min_duty + t * (max_duty - min_duty);
}

std::int64_t PwmProfile::DutyNs(double fraction) const {
  if (!std::isfinite(fraction) || fraction < 0.0) fraction = 0.0;
  if (fraction > 1.0) fraction = 1.0;
  return static_cast<std::int64_t>(std::llround(fraction * static_cast<double>(period_ns)));
}

double PwmProfile::DutyToVolts(std::int64_t duty_ns) const {
  const double fraction = static_cast<double>(duty_ns) / static_cast<double>(period_ns);
  double t = (fraction - min_duty) / (max_duty - min_duty);
  t = std::clamp(t, 0.0, 1.0);
  return command.Invert(command.min() + t * (command.max() - command.min()));
}

bool LoadPwmProfile(const std::string& path, PwmProfile* out, std::string* error) {
  std::string text;
  if (!ReadTextFile(path, 1u << 20, &text, error)) return false;
  return ParsePwmProfile(text, path, out, error);
}

bool ParsePwmProfile(const std::string& text, const std::string& path, PwmProfile* out,
                     std::string* error) {
  *out = PwmProfile{};
  out->path = path;
  const ProfileContext c{path, error};
  try {
    toml::table root;
    if (!ParseProfileToml(text, path, &root, error)) return false;
    if (const auto name = root["name"].value<std::string>()) out->name = *name;
    const toml::node* pwm = root.get("pwm");
    if (pwm == nullptr)
      return c.Fail(nullptr,
                    "pwm: no [pwm] section (period_ns, polarity, "
                    "min_duty, max_duty)");
    if (!pwm->is_table()) return c.Fail(pwm, "pwm: expected a table");
    if (!Pwm(c, *pwm->as_table(), out)) return false;
    if (!Command(c, root.get("command"), ProfileDirectory(path), out)) return false;
    out->digest = TextDigest(text, out->command.digest());
    return true;
  } catch (const std::exception& e) {
    *error = path + ": " + e.what();
    return false;
  }
}

bool ProfileHasPwm(const std::string& path) {
  std::string text, error;
  if (!ReadTextFile(path, 1u << 20, &text, &error)) return false;
  try {
    const toml::table root = toml::parse(text, path);
    return root.get("pwm") != nullptr;
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace mrd::profile
