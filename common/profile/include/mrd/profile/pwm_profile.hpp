#pragma once
// The PWM part of a device profile: a driver with a PWM or filtered-analog set-point input
// (the kernel's sysfs PWM output), read at configuration. The [command] section of the same
// file maps E [V] to the driver's set-point in its unit (command_map.hpp); the driver's input
// range [command.min, command.max] then maps linearly to the duty fraction [min_duty, max_duty]:
//
//   [pwm]
//   period_ns = 50000        PWM period [ns], integer, 1000 .. 1e9 (20 kHz here)
//   polarity = "normal"      or "inversed" (the active level; the duty is the active time)
//   min_duty = 0.0           duty fraction at command.min, in [0, 1]
//   max_duty = 0.95          duty fraction at command.max, in [0, 1], above min_duty
//   [command]                unit, calibration, min, max (both required here), slew_per_s
//
// The duty written is round(fraction x period_ns) [ns] (1 ns resolution: 1 / period_ns of the
// range). A driver simulated from the other side (mrd-hil) inverts the same maps (DutyToVolts).
// Other top-level sections (name, dbc, inputs, outputs, messages: the CAN part) are not read
// here. Configuration-time code: allocates, no exceptions out.

#include <cstdint>
#include <string>

#include "mrd/profile/command_map.hpp"

namespace mrd::profile {

struct PwmProfile {
  std::string path;          // the profile file
  std::uint64_t digest = 0;  // of the profile and its calibration (a reload compares)
  std::string name;
  std::int64_t period_ns = 50'000;
  bool inversed = false;
  double min_duty = 0.0;  // fraction of the period at command.min
  double max_duty = 1.0;  // fraction of the period at command.max
  std::string command_unit = "V";
  CommandMap command;  // E [V] -> set-point [command_unit], range [min, max], slew

  // The duty fraction for a set-point u in the command unit (clamped to the range).
  double SetpointToDuty(double u) const;
  // The duty [ns] for a duty fraction (rounded to the nearest ns, within [0, period]).
  std::int64_t DutyNs(double fraction) const;
  // The driver's side: the E [V] whose set-point the duty [ns] stands for (inverse maps; a
  // duty outside [min_duty, max_duty] is held at the range's end).
  double DutyToVolts(std::int64_t duty_ns) const;
};

// Reads the [pwm] and [command] sections of a profile file. false with *error
// "FILE:LINE: reason": no [pwm] section, period_ns not an integer in 1000 .. 1e9, a polarity
// other than "normal"/"inversed", a duty outside [0, 1] or min_duty >= max_duty, an unknown
// key in [pwm] or [command], [command] without min and max, a bad calibration curve.
bool LoadPwmProfile(const std::string& path, PwmProfile* out, std::string* error);
// The same from text; `path` names it in errors and locates a relative calibration file.
bool ParsePwmProfile(const std::string& text, const std::string& path, PwmProfile* out,
                     std::string* error);
// True when the profile text has a [pwm] section (false also when it does not parse).
bool ProfileHasPwm(const std::string& path);

}  // namespace mrd::profile
