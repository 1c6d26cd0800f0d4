#pragma once
// Velocity from a displacement sensor: a first-order filtered differentiator,
//
//   H(s) = s * wc / (s + wc),  wc = 2 pi f_c,
//   v(k) = a v(k-1) + (1 - a) (x(k) - x(k-1)) / dt,  a = exp(-wc dt)   (exact for a ramp)
//
// x [cm], v [cm/s], dt [s], f_c [Hz]. The first sample after Reset gives v = 0.
// Per-sample arithmetic in Real (real.hpp).

#include "mrd/firmware/real.hpp"

namespace mrd::firmware {

class DisplacementDifferentiator {
 public:
  // cutoff_hz > 0 (finite); returns false (unchanged) otherwise. Not real-time.
  bool Configure(double cutoff_hz);
  // As Configure, keeping the filter's state (a retune while running). Real-time safe.
  bool SetCutoff(double cutoff_hz);
  // Forgets the previous displacement. Real-time safe.
  void Reset() {
    primed_ = false;
    v_ = Real(0);
  }
  // Advances by dt [s] (> 0) to displacement x [cm]; returns the velocity estimate [cm/s].
  // A non-positive or non-finite dt, or a non-finite x, leaves the state unchanged.
  // Real-time safe.
  Real Update(Real x, Real dt);
  Real velocity() const { return v_; }
  double cutoff_hz() const { return cutoff_hz_; }

 private:
  double cutoff_hz_ = 50.0;
  Real minus_wc_ = static_cast<Real>(-2.0 * 3.14159265358979323846 * 50.0);  // -2 pi f_c
  Real x_prev_ = Real(0);
  Real v_ = Real(0);
  bool primed_ = false;
};

}  // namespace mrd::firmware
