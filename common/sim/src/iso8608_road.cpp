#include "mrd/sim/iso8608_road.hpp"

#include <cmath>
#include <numbers>

namespace mrd {
namespace {

constexpr double kN0 = 0.1;           // reference spatial frequency [cycles/m]
constexpr double kGd0ClassA = 16e-6;  // [m^3]
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// splitmix64: tiny, fully specified, so a seed gives the same road everywhere.
std::uint64_t Next(std::uint64_t* state) {
  std::uint64_t z = (*state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Uniform in [0, 1) with 53 random bits.
double Uniform(std::uint64_t* state) { return static_cast<double>(Next(state) >> 11) * 0x1p-53; }

}  // namespace

bool RoadClassFromChar(char c, RoadClass* out) {
  const char u = (c >= 'a' && c <= 'h') ? static_cast<char>(c - 'a' + 'A') : c;
  if (u < 'A' || u > 'H') return false;
  *out = static_cast<RoadClass>(u - 'A');
  return true;
}

double Iso8608Gd0(RoadClass c) {
  return kGd0ClassA * std::ldexp(1.0, 2 * static_cast<int>(c));  // x 4 per class step
}

double Iso8608Psd(RoadClass c, double n) { return Iso8608Gd0(c) * (kN0 / n) * (kN0 / n); }

double Iso8608BandVariance(RoadClass c, double a, double b) {
  return Iso8608Gd0(c) * kN0 * kN0 * (1.0 / a - 1.0 / b);
}

double Iso8608BandSlopeVariance(RoadClass c, double a, double b) {
  return kTwoPi * kTwoPi * Iso8608Gd0(c) * kN0 * kN0 * (b - a);
}

bool RoadParams::IsValid(const char** reason) const {
  const char* bad = nullptr;
  if (static_cast<int>(road_class) > static_cast<int>(RoadClass::kH)) {
    bad = "road_class";
  } else if (!std::isfinite(n_min) || !(n_min > 0.0)) {
    bad = "n_min";
  } else if (!std::isfinite(n_max) || !(n_max > n_min)) {
    bad = "n_max";
  } else if (components < 1 || components > 65536) {
    bad = "components";
  }
  if (bad != nullptr && reason != nullptr) *reason = bad;
  return bad == nullptr;
}

Iso8608Road::Iso8608Road(const RoadParams& params) : params_(params) {
  if (!params.IsValid(nullptr)) return;  // flat road
  const int n = params.components;
  omega_.resize(n);
  amp_.resize(n);
  phase_.resize(n);
  std::uint64_t rng = params.seed;
  const double ratio = params.n_max / params.n_min;
  for (int i = 0; i < n; ++i) {
    const double lo = params.n_min * std::pow(ratio, static_cast<double>(i) / n);
    const double hi = (i + 1 == n) ? params.n_max
                                   : params.n_min * std::pow(ratio, static_cast<double>(i + 1) / n);
    const double freq = lo + Uniform(&rng) * (hi - lo);
    const double var = Iso8608BandVariance(params.road_class, lo, hi);
    omega_[i] = kTwoPi * freq;
    amp_[i] = std::sqrt(2.0 * var);
    phase_[i] = kTwoPi * Uniform(&rng);
    variance_ += var;
    slope_variance_ += 0.5 * omega_[i] * omega_[i] * amp_[i] * amp_[i];
  }
}

void Iso8608Road::Evaluate(double s_m, double* height_m, double* slope) const {
  double h = 0.0, dh = 0.0;
  const std::size_t n = amp_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double arg = omega_[i] * s_m + phase_[i];
    h += amp_[i] * std::cos(arg);
    dh -= amp_[i] * omega_[i] * std::sin(arg);
  }
  *height_m = h;
  *slope = dh;
}

double Iso8608Road::Height(double s_m) const {
  double h, dh;
  Evaluate(s_m, &h, &dh);
  return h;
}

RoadTrack::RoadTrack(const Iso8608Road& road, double ds_m)
    : omega_(road.omega_), phase_(road.phase_), amp_(road.amp_), amp_omega_(road.amp_), ds_(ds_m) {
  const std::size_t n = amp_.size();
  c_.resize(n);
  s_.resize(n);
  rc_.resize(n);
  rs_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    amp_omega_[i] = amp_[i] * omega_[i];
    rc_[i] = std::cos(omega_[i] * ds_m);
    rs_[i] = std::sin(omega_[i] * ds_m);
  }
  Reset(0.0);
}

void RoadTrack::Reset(double s0_m) {
  s0_ = s0_m;
  k_ = 0;
  Anchor();
}

void RoadTrack::Anchor() {
  const double s = distance_m();
  for (std::size_t i = 0; i < c_.size(); ++i) {
    const double arg = omega_[i] * s + phase_[i];
    c_[i] = std::cos(arg);
    s_[i] = std::sin(arg);
  }
  Sum();
}

void RoadTrack::Advance() {
  ++k_;
  if (k_ % kReanchor == 0) {
    Anchor();
    return;
  }
  for (std::size_t i = 0; i < c_.size(); ++i) {
    const double c = c_[i] * rc_[i] - s_[i] * rs_[i];  // cos(a + d)
    s_[i] = s_[i] * rc_[i] + c_[i] * rs_[i];           // sin(a + d)
    c_[i] = c;
  }
  Sum();
}

void RoadTrack::Sum() {
  double h = 0.0, dh = 0.0;
  for (std::size_t i = 0; i < c_.size(); ++i) {
    h += amp_[i] * c_[i];
    dh -= amp_omega_[i] * s_[i];
  }
  height_ = h;
  slope_ = dh;
}

}  // namespace mrd
