// Forward sensitivities of the fit's simulator (spencer_sensitivity.hpp). The value part
// repeats SpencerDamper::Step / Force operation for operation (same rounding), the tangent
// part differentiates each of those operations.
#include "spencer_sensitivity.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "mrd/sim/spencer_damper.hpp"

namespace mrd::host {
namespace {

// Parameter indices (params::SpencerFields order).
enum : int { kC0a, kC0b, kK0, kC1a, kC1b, kK1, kX0, kAlphaA, kAlphaB, kGamma, kBeta, kA, kN, kEta };

using Col = std::array<double, kSpencerParamCount>;

struct State {
  double y = 0.0, z = 0.0, u = 0.0;  // [cm], [-], [V]
};

// d(y, z, u)/dp, one entry per parameter.
struct Sens {
  Col y{}, z{}, u{};
};

// Rates of (y, z, u) at one state and input, with their partial derivatives with respect to
// the state and the parameters (entries of yp/zp/up that are always 0 are never written).
struct Rates {
  double ydot = 0.0, zdot = 0.0, udot = 0.0;
  double yy = 0.0, yz = 0.0, yu = 0.0;  // d ydot / d(y, z, u)
  double zdv = 0.0, zz = 0.0;           // d zdot / d(xdot - ydot), d zdot / dz at fixed ydot
  double uu = 0.0;                      // d udot / du
  Col yp{}, zp{}, up{};                 // d(ydot, zdot, udot) / dp at fixed state
};

// As SpencerDamper::Ydot and ::Derivative (same operations, same order); zp[kN] (a log) only
// when with_n.
void Evaluate(const double* p, const State& s, double x, double xdot, double E, bool with_n,
              Rates* r) {
  const double alpha = p[kAlphaA] + p[kAlphaB] * s.u;
  const double c0 = p[kC0a] + p[kC0b] * s.u;
  const double c1 = p[kC1a] + p[kC1b] * s.u;
  const double ydot = (alpha * s.z + c0 * xdot + p[kK0] * (x - s.y)) / (c0 + c1);
  const double dv = xdot - ydot;
  const double az = std::fabs(s.z);
  const double n = p[kN];
  const double azn1 = (n == 2.0) ? az : std::pow(az, n - 1.0);
  const double azn = azn1 * az;
  const double gamma = p[kGamma], beta = p[kBeta];
  r->ydot = ydot;
  r->zdot = -gamma * std::fabs(dv) * s.z * azn1 - beta * dv * azn + p[kA] * dv;
  r->udot = -p[kEta] * (s.u - E);
  // ydot = N / D, N = alpha z + c0 xdot + k0 (x - y), D = c0 + c1.
  const double inv_d = 1.0 / (c0 + c1);
  r->yy = -p[kK0] * inv_d;
  r->yz = alpha * inv_d;
  r->yu = (p[kAlphaB] * s.z + p[kC0b] * xdot - ydot * (p[kC0b] + p[kC1b])) * inv_d;
  r->yp[kC0a] = (xdot - ydot) * inv_d;
  r->yp[kC0b] = s.u * r->yp[kC0a];
  r->yp[kK0] = (x - s.y) * inv_d;
  r->yp[kC1a] = -ydot * inv_d;
  r->yp[kC1b] = s.u * r->yp[kC1a];
  r->yp[kAlphaA] = s.z * inv_d;
  r->yp[kAlphaB] = s.u * r->yp[kAlphaA];
  // zdot = -gamma |dv| g1 - beta dv g2 + A dv, g1 = z |z|^(n-1), g2 = |z|^n:
  // dg1/dz = n |z|^(n-1), dg2/dz = n sign(z) |z|^(n-1), dg/dn = g ln|z| (0 at z = 0).
  const double sdv = dv > 0.0 ? 1.0 : (dv < 0.0 ? -1.0 : 0.0);
  const double sz = s.z > 0.0 ? 1.0 : (s.z < 0.0 ? -1.0 : 0.0);
  const double g1 = s.z * azn1;
  const double hyst = -gamma * std::fabs(dv) * g1 - beta * dv * azn;
  r->zdv = -gamma * sdv * g1 - beta * azn + p[kA];
  r->zz = -n * azn1 * (gamma * std::fabs(dv) + beta * dv * sz);
  r->zp[kGamma] = -std::fabs(dv) * g1;
  r->zp[kBeta] = -dv * azn;
  r->zp[kA] = dv;
  if (with_n) r->zp[kN] = az > 0.0 ? hyst * std::log(az) : 0.0;
  r->uu = -p[kEta];
  r->up[kEta] = -(s.u - E);
}

// Tangent of the rates for columns [j0, j1): k = d(rates)/dp along the state sensitivity s.
inline void Tangent(const Rates& r, const Sens& s, int j0, int j1, Sens* k) {
  for (int j = j0; j < j1; ++j) {
    const auto i = static_cast<std::size_t>(j);
    const double dy = r.yy * s.y[i] + r.yz * s.z[i] + r.yu * s.u[i] + r.yp[i];
    k->y[i] = dy;
    k->z[i] = -r.zdv * dy + r.zz * s.z[i] + r.zp[i];
    k->u[i] = r.uu * s.u[i] + r.up[i];
  }
}

inline void Axpy(const Sens& a, double h, const Sens& d, int j0, int j1, Sens* out) {
  for (int j = j0; j < j1; ++j) {
    const auto i = static_cast<std::size_t>(j);
    out->y[i] = a.y[i] + h * d.y[i];
    out->z[i] = a.z[i] + h * d.z[i];
    out->u[i] = a.u[i] + h * d.u[i];
  }
}

// Force (as SpencerDamper::ForceAt) and, for columns [j0, j1), its derivative (times
// col_scale) into row; r is scratch.
double Force(const double* p, const State& s, const Sens& ds, double x, double xdot, int j0, int j1,
             const double* col_scale, Rates* r, double* row) {
  Evaluate(p, s, x, xdot, 0.0, false, r);
  const double c1 = p[kC1a] + p[kC1b] * s.u;
  const double f = c1 * r->ydot + p[kK1] * (x - p[kX0]);
  if (row == nullptr) return f;
  Col fp{};
  fp[kC1a] = r->ydot;
  fp[kC1b] = s.u * r->ydot;
  fp[kK1] = x - p[kX0];
  fp[kX0] = -p[kK1];
  for (int j = j0; j < j1; ++j) {
    const auto i = static_cast<std::size_t>(j);
    const double dy = r->yy * ds.y[i] + r->yz * ds.z[i] + r->yu * ds.u[i] + r->yp[i];
    row[j] = (c1 * dy + p[kC1b] * r->ydot * ds.u[i] + fp[i]) * col_scale[j];
  }
  return f;
}

}  // namespace

bool SpencerSensitivity(const double* p, const FitRun& run, int substeps, double e_max, int j0,
                        int j1, const double* col_scale, double* residual, double* jac,
                        int stride) {
  const std::size_t rows = run.x.size();
  if (rows == 0) return true;
  const int steps = substeps < 1 ? 1 : substeps;
  const std::vector<double>& xs = run.x;
  const std::vector<double>& vs = run.v;
  State s{xs[0], 0.0, 0.0};  // SpencerDamper::Reset(x[0], 0)
  Sens S;                    // the start does not depend on p
  Rates r, r1, r2, r3, r4;
  Sens k1, k2, k3, k4, st;
  double* row = jac;
  double f = Force(p, s, S, xs[0], vs[0], j0, j1, col_scale, &r, row);
  if (residual != nullptr) residual[0] = f - run.f[0];
  const double dt = run.dt;
  const double h = dt / steps;
  const double ds = 1.0 / steps;
  const bool with_n = j0 <= kN && kN < j1;
  for (std::size_t k = 0; k + 1 < rows; ++k) {
    const double E = std::clamp(run.E[k + 1], 0.0, e_max);
    const double x0 = xs[k], v0 = vs[k], x1 = xs[k + 1], v1 = vs[k + 1];
    const auto excitation = [&](double sn, double* x, double* v) {
      HermiteExcitation(dt, x0, v0, x1, v1, sn, x, v);
    };
    for (int i = 0; i < steps; ++i) {
      const double sa = i * ds;
      double xa, va, xm, vm, xb, vb;
      excitation(sa, &xa, &va);
      excitation(sa + 0.5 * ds, &xm, &vm);
      excitation(sa + ds, &xb, &vb);
      Evaluate(p, s, xa, va, E, with_n, &r1);
      Tangent(r1, S, j0, j1, &k1);
      const State s2{s.y + 0.5 * h * r1.ydot, s.z + 0.5 * h * r1.zdot, s.u + 0.5 * h * r1.udot};
      Axpy(S, 0.5 * h, k1, j0, j1, &st);
      Evaluate(p, s2, xm, vm, E, with_n, &r2);
      Tangent(r2, st, j0, j1, &k2);
      const State s3{s.y + 0.5 * h * r2.ydot, s.z + 0.5 * h * r2.zdot, s.u + 0.5 * h * r2.udot};
      Axpy(S, 0.5 * h, k2, j0, j1, &st);
      Evaluate(p, s3, xm, vm, E, with_n, &r3);
      Tangent(r3, st, j0, j1, &k3);
      const State s4{s.y + h * r3.ydot, s.z + h * r3.zdot, s.u + h * r3.udot};
      Axpy(S, h, k3, j0, j1, &st);
      Evaluate(p, s4, xb, vb, E, with_n, &r4);
      Tangent(r4, st, j0, j1, &k4);
      s.y += h / 6.0 * (r1.ydot + 2 * r2.ydot + 2 * r3.ydot + r4.ydot);
      s.z += h / 6.0 * (r1.zdot + 2 * r2.zdot + 2 * r3.zdot + r4.zdot);
      s.u += h / 6.0 * (r1.udot + 2 * r2.udot + 2 * r3.udot + r4.udot);
      for (int j = j0; j < j1; ++j) {
        const auto c = static_cast<std::size_t>(j);
        S.y[c] += h / 6.0 * (k1.y[c] + 2 * k2.y[c] + 2 * k3.y[c] + k4.y[c]);
        S.z[c] += h / 6.0 * (k1.z[c] + 2 * k2.z[c] + 2 * k3.z[c] + k4.z[c]);
        S.u[c] += h / 6.0 * (k1.u[c] + 2 * k2.u[c] + 2 * k3.u[c] + k4.u[c]);
      }
    }
    if (row != nullptr) row += stride;
    f = Force(p, s, S, x1, v1, j0, j1, col_scale, &r, row);
    if (!std::isfinite(f) || std::fabs(f) > 1e9) return false;
    if (residual != nullptr) residual[k + 1] = f - run.f[k + 1];
  }
  return true;
}

}  // namespace mrd::host
