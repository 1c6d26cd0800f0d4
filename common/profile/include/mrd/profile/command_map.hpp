#pragma once
// The way from the model's command E [V] to the driver's set-point: a piecewise-linear
// calibration (e.g. a coil's measured E-I curve), the driver's range, a slew-rate limit. Set
// up at configuration; Apply runs in the loop (no allocation, no exceptions).
//
//   [command]  unit = "A"            the driver's set-point unit (label only)
//              calibration = "F.csv" two columns with a header naming E and the unit's value,
//                                    E strictly increasing, the value strictly monotonic
//                                    (absent: the set-point is E itself)
//              min = 0, max = 2      the driver's range in its unit (clamped)
//              slew_per_s = 40       largest change per second in the unit (0: no limit)
// Below the first or above the last calibration point the end segments are held (no
// extrapolation): the clamp to [min, max] then applies.

#include <array>
#include <cstdint>
#include <string>

namespace mrd::profile {

class CommandMap {
 public:
  static constexpr std::size_t kMaxPoints = 64;

  // Identity (set-point = E), no range, no slew limit.
  CommandMap() = default;

  // Reads the calibration CSV; false with *error "FILE:LINE: reason" (fewer than 2 or more
  // than 64 points, a non-numeric or non-finite value, E not strictly increasing, the value not
  // strictly monotonic).
  bool LoadCalibration(const std::string& path, std::string* error);
  // false with *error when min >= max, a bound is not finite, or slew_per_s < 0.
  bool SetRange(double min, double max, double slew_per_s, std::string* error);

  // The set-point for command e [V] after dt_s since the previous one (the slew limit's step;
  // the first call is not limited). Non-finite e gives the range's bound nearest 0 (or 0).
  double Apply(double e, double dt_s);
  // The calibration alone (no range, no slew): set-point for e.
  double Calibrate(double e) const;
  // The calibration's inverse (the E that gives set-point u; held at the curve's ends): what a
  // simulated driver applies for a set-point it hears.
  double Invert(double u) const;
  // Forget the previous set-point (the next Apply is not slew-limited).
  void Reset() { have_last_ = false; }
  // The set-point of the safe state for command e [V]: the calibration clamped to the range,
  // never rate-limited (what Apply gives after Reset; a non-finite e as Apply).
  double SafeSetpoint(double e) const;
  // The driver's off: of the set-points the map gives for commands E >= 0 V (the range when
  // [command] gives one, else the calibration's values from E = 0 on, or E itself), the one
  // nearest 0 (0 for a range across 0; the range's min for one above 0, e.g. 4..20 mA).
  double Off() const;
  // The set-points commands E in [0, e_max] [V] reach: *lo and *hi (the range when given).
  void Reach(double e_max, double* lo, double* hi) const;
  // [command] gave min and max.
  bool has_range() const { return min_ > -1e300 || max_ < 1e300; }
  // The calibration's values fall as E rises.
  bool decreasing() const { return n_ >= 2 && u_[n_ - 1] < u_[0]; }

  std::size_t points() const { return n_; }
  // Of the calibration file's text (0: none).
  std::uint64_t digest() const { return digest_; }
  double min() const { return min_; }
  double max() const { return max_; }

 private:
  std::array<double, kMaxPoints> e_{}, u_{};
  std::size_t n_ = 0;
  double min_ = -1e300, max_ = 1e300;
  double slew_ = 0.0;
  double last_ = 0.0;
  bool have_last_ = false;
  std::uint64_t digest_ = 0;
};

}  // namespace mrd::profile
