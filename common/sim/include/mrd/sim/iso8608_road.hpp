#pragma once
// ISO 8608 random road profile: displacement PSD of class A..H
//
//   Gd(n) = Gd(n0) (n / n0)^-w,  n0 = 0.1 cycles/m, w = 2,
//   Gd(n0) = 16e-6 m^3 * 4^k  (k = 0 for class A .. 7 for class H; the class's geometric mean),
//
// realised as a sum of cosines over the band [n_min, n_max] (default 0.011..2.83 cycles/m, the
// standard's band: wavelengths 91 m .. 0.35 m):
//
//   h(s) = sum_i a_i cos(2 pi n_i s + phi_i)                                   [m]
//
// The band is cut into `components` log-spaced bins [e_i, e_i+1]; a_i = sqrt(2 int Gd dn over
// the bin), so sum a_i^2 / 2 is exactly the band integral of Gd (the ensemble variance);
// n_i is drawn uniformly inside its bin and phi_i uniformly in [0, 2 pi) from the seed (a
// splitmix64 stream: the same seed gives the same road on every platform). The jitter keeps
// the profile from repeating; the amplitudes depend on the class alone, so two classes with
// one seed differ by a factor 2 per class step in height (4 in variance).
//
// Evaluate at distance s = speed * t. Allocation only in the constructor; the evaluations are
// pure and real-time safe (components cosines per call).

#include <cstdint>
#include <vector>

namespace mrd {

enum class RoadClass : std::uint8_t { kA = 0, kB, kC, kD, kE, kF, kG, kH };

// 'A'..'H' (either case); false for anything else.
bool RoadClassFromChar(char c, RoadClass* out);
// Gd(n0) of the class [m^3].
double Iso8608Gd0(RoadClass c);
// Gd(n) [m^3] at spatial frequency n > 0 [cycles/m].
double Iso8608Psd(RoadClass c, double n);
// Integral of Gd over [a, b] [m^2] (0 < a <= b): Gd(n0) n0^2 (1/a - 1/b).
double Iso8608BandVariance(RoadClass c, double a, double b);
// Integral of (2 pi n)^2 Gd over [a, b] [-]: the variance of the slope dh/ds (w = 2 makes the
// slope PSD flat: 4 pi^2 Gd(n0) n0^2 (b - a)).
double Iso8608BandSlopeVariance(RoadClass c, double a, double b);

struct RoadParams {
  RoadClass road_class = RoadClass::kC;
  std::uint64_t seed = 1;
  double n_min = 0.011;  // lowest spatial frequency [cycles/m], > 0
  double n_max = 2.83;   // highest [cycles/m], > n_min
  int components = 256;  // cosines (log-spaced bins), 1..65536

  // True when the values are finite and in range; on failure *reason names the field.
  bool IsValid(const char** reason) const;
};

class Iso8608Road {
 public:
  // Invalid parameters (IsValid false) give a flat road (no components, h = 0).
  explicit Iso8608Road(const RoadParams& params);

  // Height h [m] and slope dh/ds [-] at distance s [m] (any s, also negative).
  void Evaluate(double s_m, double* height_m, double* slope) const;
  double Height(double s_m) const;

  // Ensemble variances of this realisation: sum a_i^2/2 [m^2] and sum (2 pi n_i a_i)^2/2 [-].
  double variance() const { return variance_; }
  double slope_variance() const { return slope_variance_; }
  int size() const { return static_cast<int>(amp_.size()); }
  const RoadParams& params() const { return params_; }

 private:
  friend class RoadTrack;
  RoadParams params_;
  std::vector<double> omega_;  // 2 pi n_i [rad/m]
  std::vector<double> amp_;    // a_i [m]
  std::vector<double> phase_;  // phi_i [rad]
  double variance_ = 0.0;
  double slope_variance_ = 0.0;
};

// The road along equally spaced distances s0 + k ds, as a plant steps it: each component's
// phasor (cos, sin) is rotated by omega_i ds per Advance (a few multiplications instead of a
// cosine and a sine), re-anchored exactly every kReanchor steps so rounding cannot drift
// (agrees with Evaluate to ~1e-13 m). Holds its own copy of the components (no reference to
// the road). Allocation only in the constructor.
class RoadTrack {
 public:
  static constexpr int kReanchor = 1024;
  RoadTrack(const Iso8608Road& road, double ds_m);
  // Exact at distance s0 [m]. Real-time safe.
  void Reset(double s0_m);
  // To the next distance. Real-time safe.
  void Advance();
  double distance_m() const { return s0_ + static_cast<double>(k_) * ds_; }
  double height_m() const { return height_; }
  double slope() const { return slope_; }

 private:
  void Anchor();
  void Sum();
  std::vector<double> omega_, phase_, amp_, amp_omega_;  // copies of the road's components
  double ds_;
  double s0_ = 0.0;
  std::int64_t k_ = 0;
  std::vector<double> c_, s_;    // cos, sin of each component's phase
  std::vector<double> rc_, rs_;  // cos, sin of omega_i ds
  double height_ = 0.0, slope_ = 0.0;
};

}  // namespace mrd
