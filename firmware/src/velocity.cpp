#include "mrd/firmware/velocity.hpp"

#include <cmath>
#include <numbers>

namespace mrd::firmware {

bool DisplacementDifferentiator::Configure(double cutoff_hz) {
  if (!SetCutoff(cutoff_hz)) return false;
  Reset();
  return true;
}

bool DisplacementDifferentiator::SetCutoff(double cutoff_hz) {
  if (!std::isfinite(cutoff_hz) || !(cutoff_hz > 0.0)) return false;
  cutoff_hz_ = cutoff_hz;
  minus_wc_ = static_cast<Real>(-2.0 * std::numbers::pi * cutoff_hz);
  return true;
}

Real DisplacementDifferentiator::Update(Real x, Real dt) {
  if (!std::isfinite(x) || !std::isfinite(dt) || !(dt > Real(0))) return v_;
  if (!primed_) {
    primed_ = true;
    x_prev_ = x;
    v_ = Real(0);
    return v_;
  }
  const Real a = std::exp(minus_wc_ * dt);
  v_ = a * v_ + (Real(1) - a) * (x - x_prev_) / dt;
  x_prev_ = x;
  return v_;
}

}  // namespace mrd::firmware
