#include "mrd/sim/shear_frame.hpp"

#include <cmath>

namespace mrd {

bool ShearFrameParams::IsValid(const char** reason) const {
  for (double m : mass_kg) {
    if (!std::isfinite(m) || !(m > 0.0)) {
      if (reason != nullptr) *reason = "mass_kg";
      return false;
    }
  }
  for (int i = 0; i < kFloors * kFloors; ++i) {
    if (!std::isfinite(stiffness[i])) {
      if (reason != nullptr) *reason = "stiffness";
      return false;
    }
    if (!std::isfinite(damping[i])) {
      if (reason != nullptr) *reason = "damping";
      return false;
    }
  }
  return true;
}

ShearFrame::ShearFrame(const ShearFrameParams& frame, const SpencerParams& damper, int substeps)
    : frame_(frame), damper_(damper, 1), substeps_(substeps < 1 ? 1 : substeps) {
  // Force at rest at x_d = 0: c1 ydot = 0 there, so f0 = k1 (0 - x0).
  f0_ = damper.k1 * (0.0 - damper.x0);
  Reset(0.0, 0.0);
}

void ShearFrame::Reset(double E, double ag) {
  state_ = State{};
  state_.d.u = E;
  double accel[kN];
  double force = 0.0;
  Rate(state_, ag, E, accel, &force);
  sample_ = ShearFrameSample{};
  for (int i = 0; i < kN; ++i) sample_.xa[i] = accel[i] + ag;
  sample_.force = force;
}

ShearFrame::State ShearFrame::Rate(const State& s, double ag, double E, double* accel,
                                   double* force) const {
  State r{};
  double f = 0.0;
  if (frame_.with_damper) {
    const double xd = 100.0 * s.x[0];  // [cm]
    const double vd = 100.0 * s.v[0];  // [cm/s]
    r.d = damper_.Derivative(s.d, xd, vd, E);
    f = damper_.ForceAt(s.d, xd, vd) - f0_;
  }
  for (int i = 0; i < kN; ++i) {
    double sum = -frame_.mass_kg[i] * ag;
    if (i == 0) sum -= f;  // Gamma = [-1, 0, 0]
    for (int j = 0; j < kN; ++j) {
      sum -= frame_.stiffness[i * kN + j] * s.x[j] + frame_.damping[i * kN + j] * s.v[j];
    }
    r.x[i] = s.v[i];
    r.v[i] = sum / frame_.mass_kg[i];
    accel[i] = r.v[i];
  }
  *force = f;
  return r;
}

const ShearFrameSample& ShearFrame::Step(double dt, double ag0, double ag1, double E) {
  const double h = dt / substeps_;
  const auto axpy = [](const State& a, double k, const State& d) {
    State o;
    for (int i = 0; i < kN; ++i) {
      o.x[i] = a.x[i] + k * d.x[i];
      o.v[i] = a.v[i] + k * d.v[i];
    }
    o.d = SpencerState{a.d.y + k * d.d.y, a.d.z + k * d.d.z, a.d.u + k * d.d.u};
    return o;
  };
  double accel[kN];
  double force = 0.0;
  State s = state_;
  for (int n = 0; n < substeps_; ++n) {
    const double ta = static_cast<double>(n) / substeps_;
    const double tm = (n + 0.5) / substeps_;
    const double tb = static_cast<double>(n + 1) / substeps_;
    const double aga = ag0 + (ag1 - ag0) * ta;
    const double agm = ag0 + (ag1 - ag0) * tm;
    const double agb = ag0 + (ag1 - ag0) * tb;
    const State k1 = Rate(s, aga, E, accel, &force);
    const State k2 = Rate(axpy(s, 0.5 * h, k1), agm, E, accel, &force);
    const State k3 = Rate(axpy(s, 0.5 * h, k2), agm, E, accel, &force);
    const State k4 = Rate(axpy(s, h, k3), agb, E, accel, &force);
    for (int i = 0; i < kN; ++i) {
      s.x[i] += h / 6.0 * (k1.x[i] + 2 * k2.x[i] + 2 * k3.x[i] + k4.x[i]);
      s.v[i] += h / 6.0 * (k1.v[i] + 2 * k2.v[i] + 2 * k3.v[i] + k4.v[i]);
    }
    s.d.y += h / 6.0 * (k1.d.y + 2 * k2.d.y + 2 * k3.d.y + k4.d.y);
    s.d.z += h / 6.0 * (k1.d.z + 2 * k2.d.z + 2 * k3.d.z + k4.d.z);
    s.d.u += h / 6.0 * (k1.d.u + 2 * k2.d.u + 2 * k3.d.u + k4.d.u);
  }
  state_ = s;
  Rate(state_, ag1, E, accel, &force);
  for (int i = 0; i < kN; ++i) {
    sample_.x[i] = state_.x[i];
    sample_.v[i] = state_.v[i];
    sample_.xa[i] = accel[i] + ag1;
  }
  sample_.force = force;
  return sample_;
}

}  // namespace mrd
