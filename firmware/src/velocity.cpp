#include "mrd/firmware/velocity.hpp"

#include <cmath>
#include <numbers>

namespace mrd::firmware {

bool DisplacementDifferentiator::Configure(double cutoff_hz) {
  if (!std::isfinite(cutoff_hz) || !(cutoff_hz > 0.0)) return false;
  cutoff_hz_ = cutoff_hz;
  Reset();
  return true;
}

double DisplacementDifferentiator::Update(double x, double dt) {
  if (!std::isfinite(x) || !std::isfinite(dt) || !(dt > 0.0)) return v_;
  if (!primed_) {
    primed_ = true;
    x_prev_ = x;
    v_ = 0.0;
    return v_;
  }
  const double a = std::exp(-2.0 * std::numbers::pi * cutoff_hz_ * dt);
  v_ = a * v_ + (1.0 - a) * (x - x_prev_) / dt;
  x_prev_ = x;
  return v_;
}

}  // namespace mrd::firmware
