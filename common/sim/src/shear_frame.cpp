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
  if (dampers < 1 || dampers > kMaxDampers) {
    if (reason != nullptr) *reason = "dampers";
    return false;
  }
  for (int j = 0; j < dampers; ++j) {
    if (story[j] < 1 || story[j] > kFloors || (j > 0 && story[j] <= story[j - 1])) {
      if (reason != nullptr) *reason = "story";
      return false;
    }
  }
  return true;
}

ShearFrame::ShearFrame(const ShearFrameParams& frame, const SpencerParams& damper, int substeps)
    : frame_(frame), damper_(damper, 1), substeps_(substeps < 1 ? 1 : substeps) {
  // Force at rest at x_d = 0: c1 ydot = 0 there, so f0 = k1 (0 - x0).
  f0_ = damper.k1 * (0.0 - damper.x0);
  // An invalid damper set (IsValid false) runs as the bare frame rather than index past it.
  if (!frame_.IsValid(nullptr)) frame_.with_damper = false;
  Reset(0.0, 0.0);
}

void ShearFrame::Reset(double E, double ag) {
  state_ = State{};
  double volts[kD];
  for (int j = 0; j < kD; ++j) {
    state_.d[j].u = E;
    volts[j] = E;
  }
  double accel[kN];
  double force[kD];
  Rate(state_, ag, volts, accel, force);
  sample_ = ShearFrameSample{};
  Publish(accel, force, ag);
}

void ShearFrame::Publish(const double* accel, const double* force, double ag) {
  for (int i = 0; i < kN; ++i) {
    sample_.x[i] = state_.x[i];
    sample_.v[i] = state_.v[i];
    sample_.xa[i] = accel[i] + ag;
  }
  for (int j = 0; j < kD; ++j) sample_.forces[j] = force[j];
  sample_.force = force[0];
}

ShearFrame::State ShearFrame::Rate(const State& s, double ag, const double* E, double* accel,
                                   double* force) const {
  State r{};
  const int nd = Dampers();
  int upper[kD], lower[kD];  // floor index above / below damper j (-1: the ground)
  for (int j = 0; j < kD; ++j) force[j] = 0.0;
  for (int j = 0; j < nd; ++j) {
    upper[j] = frame_.story[j] - 1;
    lower[j] = upper[j] - 1;
    const int a = upper[j], b = lower[j];
    const double xd = 100.0 * (b < 0 ? s.x[a] : s.x[a] - s.x[b]);  // drift [cm]
    const double vd = 100.0 * (b < 0 ? s.v[a] : s.v[a] - s.v[b]);  // [cm/s]
    r.d[j] = damper_.Derivative(s.d[j], xd, vd, E[j]);
    force[j] = damper_.ForceAt(s.d[j], xd, vd) - f0_;
  }
  for (int i = 0; i < kN; ++i) {
    double sum = -frame_.mass_kg[i] * ag;
    for (int j = 0; j < nd; ++j) {  // Gamma: -f on the floor above, +f on the floor below
      if (upper[j] == i) sum -= force[j];
      if (lower[j] == i) sum += force[j];
    }
    for (int j = 0; j < kN; ++j) {
      sum -= frame_.stiffness[i * kN + j] * s.x[j] + frame_.damping[i * kN + j] * s.v[j];
    }
    r.x[i] = s.v[i];
    r.v[i] = sum / frame_.mass_kg[i];
    accel[i] = r.v[i];
  }
  return r;
}

const ShearFrameSample& ShearFrame::Step(double dt, double ag0, double ag1, double E) {
  double volts[kD];
  for (double& v : volts) v = E;
  return Step(dt, ag0, ag1, volts);
}

const ShearFrameSample& ShearFrame::Step(double dt, double ag0, double ag1, const double* E) {
  const double h = dt / substeps_;
  const int nd = Dampers();
  const auto axpy = [nd](const State& a, double k, const State& d) {
    State o;
    for (int i = 0; i < kN; ++i) {
      o.x[i] = a.x[i] + k * d.x[i];
      o.v[i] = a.v[i] + k * d.v[i];
    }
    for (int j = 0; j < nd; ++j) {
      o.d[j] =
          SpencerState{a.d[j].y + k * d.d[j].y, a.d[j].z + k * d.d[j].z, a.d[j].u + k * d.d[j].u};
    }
    return o;
  };
  double accel[kN];
  double force[kD];
  State s = state_;
  for (int n = 0; n < substeps_; ++n) {
    const double ta = static_cast<double>(n) / substeps_;
    const double tm = (n + 0.5) / substeps_;
    const double tb = static_cast<double>(n + 1) / substeps_;
    const double aga = ag0 + (ag1 - ag0) * ta;
    const double agm = ag0 + (ag1 - ag0) * tm;
    const double agb = ag0 + (ag1 - ag0) * tb;
    const State k1 = Rate(s, aga, E, accel, force);
    const State k2 = Rate(axpy(s, 0.5 * h, k1), agm, E, accel, force);
    const State k3 = Rate(axpy(s, 0.5 * h, k2), agm, E, accel, force);
    const State k4 = Rate(axpy(s, h, k3), agb, E, accel, force);
    for (int i = 0; i < kN; ++i) {
      s.x[i] += h / 6.0 * (k1.x[i] + 2 * k2.x[i] + 2 * k3.x[i] + k4.x[i]);
      s.v[i] += h / 6.0 * (k1.v[i] + 2 * k2.v[i] + 2 * k3.v[i] + k4.v[i]);
    }
    for (int j = 0; j < nd; ++j) {
      SpencerState& d = s.d[j];
      d.y += h / 6.0 * (k1.d[j].y + 2 * k2.d[j].y + 2 * k3.d[j].y + k4.d[j].y);
      d.z += h / 6.0 * (k1.d[j].z + 2 * k2.d[j].z + 2 * k3.d[j].z + k4.d[j].z);
      d.u += h / 6.0 * (k1.d[j].u + 2 * k2.d[j].u + 2 * k3.d[j].u + k4.d[j].u);
    }
  }
  state_ = s;
  Rate(state_, ag1, E, accel, force);
  Publish(accel, force, ag1);
  return sample_;
}

}  // namespace mrd
