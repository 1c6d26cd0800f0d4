#include "mrd/host/command_range.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "mrd/common/table.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/profile/pwm_profile.hpp"

namespace mrd::host {
namespace {

// Bounds of the range CommandMap holds when the profile sets none.
constexpr double kNoRange = 1e299;

// "FILE:LINE: reason" of the profile loaders as an InputError.
InputError ProfileError(const std::string& path, const std::string& error) {
  const std::string prefix = path + ":";
  if (error.rfind(prefix, 0) == 0) {
    const std::string rest = error.substr(prefix.size());
    char* end = nullptr;
    const unsigned long line = std::strtoul(rest.c_str(), &end, 10);
    if (end != rest.c_str() && *end == ':') {
      return InputError(path, line, std::string(end + 1 + (end[1] == ' ' ? 1 : 0)));
    }
  }
  return InputError(path, 0, error);
}

std::string Range(double lo, double hi) { return fmt::format("[{:.4g}, {:.4g}] V", lo, hi); }

}  // namespace

std::pair<double, double> ProfileCommandRange(const std::string& path) {
  std::string error;
  profile::CommandMap map;
  if (profile::IsModbusProfileFile(path)) {
    profile::ModbusProfile p;
    if (!profile::LoadModbusProfile(path, &p, &error)) throw ProfileError(path, error);
    map = p.command;
  } else if (profile::ProfileHasPwm(path)) {
    profile::PwmProfile p;
    if (!profile::LoadPwmProfile(path, &p, &error)) throw ProfileError(path, error);
    map = p.command;
  } else {
    profile::CanProfile p;
    if (!profile::LoadCanProfile(path, &p, &error)) throw ProfileError(path, error);
    map = p.command;
  }
  if (!(map.min() > -kNoRange && map.max() < kNoRange)) {
    throw InputError(path, 0,
                     "the profile's [command] sets no min and max: no command range to export "
                     "the table for (give --e-min/--e-max)");
  }
  double lo = map.min(), hi = map.max();
  if (map.points() > 0) {  // the driver's unit back to E through the calibration
    lo = map.Invert(map.min());
    hi = map.Invert(map.max());
    if (lo > hi) std::swap(lo, hi);
  }
  return {lo, hi};
}

CommandRange ChooseCommandRange(const ModelFile& m, const std::string& input,
                                std::optional<double> e_min, std::optional<double> e_max,
                                const std::string& profile) {
  CommandRange r;
  const auto ch = std::find_if(m.channels.begin(), m.channels.end(),
                               [&](const ChannelInfo& c) { return c.name == input; });
  const bool has_data = ch != m.channels.end() && ch->has_range;
  if (!profile.empty()) {
    std::tie(r.e_min, r.e_max) = ProfileCommandRange(profile);
    r.source = fmt::format("the command range of {}", profile);
  } else if (has_data) {
    r.e_min = std::clamp(ch->min, 0.0, kMaxCommandVoltage);
    r.e_max = std::clamp(ch->max, 0.0, kMaxCommandVoltage);
    r.source = fmt::format(
        "the range '{}' reached in the identification data{}", input,
        r.e_min != ch->min || r.e_max != ch->max
            ? fmt::format(" {}, within [0, {:g}] V", Range(ch->min, ch->max), kMaxCommandVoltage)
            : std::string());
  } else {
    r.source = "the default [0, 2.25] V (the model file records no envelope)";
  }
  if (e_min) r.e_min = *e_min;
  if (e_max) r.e_max = *e_max;
  if (e_min || e_max)
    r.source = "--e-min/--e-max" + std::string(e_min && e_max ? "" : " and " + r.source);
  if (!has_data) return r;
  const std::string table = Range(r.e_min, r.e_max), data = Range(ch->min, ch->max);
  if (ch->min < r.e_min || ch->max > r.e_max) {
    r.warnings.push_back(fmt::format(
        "warning: {}: the identification data reach '{}' {}, beyond the table's range {}: the "
        "model is neither checked nor inverted there",
        m.path, input, data, table));
  }
  if (r.e_min < ch->min || r.e_max > ch->max) {
    r.warnings.push_back(fmt::format(
        "warning: {}: the table's range {} reaches beyond the identification data's '{}' {}: "
        "the model extrapolates there",
        m.path, table, input, data));
  }
  return r;
}

}  // namespace mrd::host
