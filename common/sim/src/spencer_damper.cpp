#include "mrd/sim/spencer_damper.hpp"

#include <cmath>

#include "param_fields.hpp"

namespace mrd {

SpencerParams SpencerParams::Spencer1997() {
  SpencerParams p;
  p.c0a = 21.0;
  p.c0b = 3.50;
  p.k0 = 46.9;
  p.c1a = 283.0;
  p.c1b = 2.95;
  p.k1 = 5.00;
  p.x0 = 14.3;
  p.alpha_a = 140.0;
  p.alpha_b = 695.0;
  p.gamma = 363.0;
  p.beta = 363.0;
  p.A = 301.0;
  p.n = 2.0;
  p.eta = 190.0;
  return p;
}

bool SpencerParams::FromPreset(std::string_view name, SpencerParams* out) {
  if (name == "paper") {
    *out = Paper();
    return true;
  }
  if (name == "spencer1997") {
    *out = Spencer1997();
    return true;
  }
  return false;
}

bool SpencerParams::IsValid(const char** reason) const {
  return sim_internal::FieldsValid(
      {
          {"c0a", c0a, c0a > 0.0},
          {"c0b", c0b, true},
          {"k0", k0, k0 > 0.0},
          {"c1a", c1a, c1a > 0.0},
          {"c1b", c1b, true},
          {"k1", k1, true},
          {"x0", x0, true},
          {"alpha_a", alpha_a, true},
          {"alpha_b", alpha_b, true},
          {"gamma", gamma, true},
          {"beta", beta, true},
          {"A", A, true},
          {"n", n, n > 0.0},
          {"eta", eta, eta > 0.0},
      },
      reason);
}

SpencerDamper::SpencerDamper(const SpencerParams& params, int substeps)
    : params_(params), substeps_(substeps < 1 ? 1 : substeps) {}

void SpencerDamper::Reset(double x, double E) {
  state_.y = x;
  state_.z = 0.0;
  state_.u = E;
}

double SpencerDamper::Ydot(const SpencerState& s, double x, double xdot) const {
  const SpencerParams& p = params_;
  const double alpha = p.alpha_a + p.alpha_b * s.u;
  const double c0 = p.c0a + p.c0b * s.u;
  const double c1 = p.c1a + p.c1b * s.u;
  return (alpha * s.z + c0 * xdot + p.k0 * (x - s.y)) / (c0 + c1);
}

SpencerState SpencerDamper::Derivative(const SpencerState& s, double x, double xdot,
                                       double E) const {
  const SpencerParams& p = params_;
  const double ydot = Ydot(s, x, xdot);
  const double dv = xdot - ydot;
  const double az = std::fabs(s.z);
  // |z|^(n-1) and |z|^n; n == 2 is the common case and avoids pow().
  const double azn1 = (p.n == 2.0) ? az : std::pow(az, p.n - 1.0);
  const double azn = azn1 * az;
  SpencerState d;
  d.y = ydot;
  d.z = -p.gamma * std::fabs(dv) * s.z * azn1 - p.beta * dv * azn + p.A * dv;
  d.u = -p.eta * (s.u - E);
  return d;
}

double SpencerDamper::Force(double x, double xdot) const { return ForceAt(state_, x, xdot); }

double SpencerDamper::ForceAt(const SpencerState& at, double x, double xdot) const {
  const SpencerParams& p = params_;
  const double c1 = p.c1a + p.c1b * at.u;
  return c1 * Ydot(at, x, xdot) + p.k1 * (x - p.x0);
}

double SpencerDamper::Step(double dt, double x0, double v0, double x1, double v1, double E) {
  const auto excitation = [&](double s, double* x, double* v) {
    HermiteExcitation(dt, x0, v0, x1, v1, s, x, v);
  };
  const auto axpy = [](const SpencerState& a, double h, const SpencerState& d) {
    return SpencerState{a.y + h * d.y, a.z + h * d.z, a.u + h * d.u};
  };
  const double h = dt / substeps_;
  const double ds = 1.0 / substeps_;
  SpencerState s = state_;
  for (int i = 0; i < substeps_; ++i) {
    const double sa = i * ds;
    double xa, va, xm, vm, xb, vb;
    excitation(sa, &xa, &va);
    excitation(sa + 0.5 * ds, &xm, &vm);
    excitation(sa + ds, &xb, &vb);
    const SpencerState k1 = Derivative(s, xa, va, E);
    const SpencerState k2 = Derivative(axpy(s, 0.5 * h, k1), xm, vm, E);
    const SpencerState k3 = Derivative(axpy(s, 0.5 * h, k2), xm, vm, E);
    const SpencerState k4 = Derivative(axpy(s, h, k3), xb, vb, E);
    s.y += h / 6.0 * (k1.y + 2 * k2.y + 2 * k3.y + k4.y);
    s.z += h / 6.0 * (k1.z + 2 * k2.z + 2 * k3.z + k4.z);
    s.u += h / 6.0 * (k1.u + 2 * k2.u + 2 * k3.u + k4.u);
  }
  state_ = s;
  return Force(x1, v1);
}

}  // namespace mrd
