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

  std::size_t points() const { return n_; }
  double min() const { return min_; }
  double max() const { return max_; }

 private:
  std::array<double, kMaxPoints> e_{}, u_{};
  std::size_t n_ = 0;
  double min_ = -1e300, max_ = 1e300;
  double slew_ = 0.0;
  double last_ = 0.0;
  bool have_last_ = false;
};

}  // namespace mrd::profile
