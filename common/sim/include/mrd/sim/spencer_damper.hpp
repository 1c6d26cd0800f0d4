#pragma once
// Spencer et al. (1997) phenomenological MR damper model, the reference plant of the toolkit
// (data generator, HIL server, firmware dry-run driver). Pure and allocation-free.
//
//   f     = c1*ydot + k1*(x - x0)                                      [N]
//   ydot  = (alpha*z + c0*xdot + k0*(x - y)) / (c0 + c1)               [cm/s]
//   zdot  = -gamma*|xdot - ydot|*z*|z|^(n-1) - beta*(xdot - ydot)*|z|^n + A*(xdot - ydot)
//   alpha = alpha_a + alpha_b*u,  c0 = c0a + c0b*u,  c1 = c1a + c1b*u
//   udot  = -eta*(u - E)
//
// Units: x [cm], xdot [cm/s], E and u [V], f [N], t [s]. (The seed paper drops the
// 1/(c0 + c1) factor in ydot; this is the correct form.)

#include <string_view>

namespace mrd {

struct SpencerParams {
  double c0a = 20.2;       // [N s/cm]
  double c0b = 2.68;       // [N s/(cm V)]
  double k0 = 15.0;        // [N/cm]
  double c1a = 350.0;      // [N s/cm]
  double c1b = 70.7;       // [N s/(cm V)]
  double k1 = 5.37;        // [N/cm]
  double x0 = 0.0;         // [cm]
  double alpha_a = 44.9;   // [N/cm]
  double alpha_b = 638.0;  // [N/(cm V)]
  double gamma = 39.3;     // [1/cm^2]
  double beta = 39.3;      // [1/cm^2]
  double A = 47.2;         // [-]
  double n = 2.0;          // [-], > 0
  double eta = 251.0;      // [1/s]

  // The seed paper's values (default).
  static SpencerParams Paper() { return SpencerParams{}; }
  // Spencer et al. 1997, Table 1.
  static SpencerParams Spencer1997();
  // Preset by name ("paper", "spencer1997"); returns false for an unknown name.
  static bool FromPreset(std::string_view name, SpencerParams* out);

  // True when every value is finite and the physical ones are positive (c0a, c1a, k0, eta, n).
  // On failure *reason names the offending field (static string).
  bool IsValid(const char** reason) const;
};

struct SpencerState {
  double y = 0.0;  // internal displacement [cm]
  double z = 0.0;  // evolutionary (hysteretic) variable [-]
  double u = 0.0;  // filtered voltage [V]
};

// Cubic Hermite interpolant on one sample interval [0, dt] through (x0, v0) and (x1, v1):
// position *x [cm] and velocity *v [cm/s] at normalised time s in [0, 1].
inline void HermiteExcitation(double dt, double x0, double v0, double x1, double v1, double s,
                              double* x, double* v) {
  const double s2 = s * s;
  const double s3 = s2 * s;
  const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s;
  const double h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
  *x = h00 * x0 + h10 * dt * v0 + h01 * x1 + h11 * dt * v1;
  const double d00 = 6 * s2 - 6 * s, d10 = 3 * s2 - 4 * s + 1;
  const double d01 = -6 * s2 + 6 * s, d11 = 3 * s2 - 2 * s;
  *v = (d00 * x0 + d01 * x1) / dt + d10 * v0 + d11 * v1;
}

// Fixed-step RK4 integration of the model over sampling intervals. Within one interval the
// displacement follows the cubic Hermite interpolant of (x, xdot) at both ends and E is held
// (zero-order hold, as a current driver holds its command).
class SpencerDamper {
 public:
  // substeps: RK4 steps per sample interval (>= 1). 1 ms / 100 = 10 us is converged to < 1e-6
  // relative force for both presets (tests/common/spencer_damper_test.cpp).
  explicit SpencerDamper(const SpencerParams& params, int substeps = 100);

  // Starts at rest at displacement x [cm] with the voltage filter settled at E [V].
  void Reset(double x, double E);

  // Advances one interval dt [s] from (x0, v0) to (x1, v1) with E held; returns the force [N]
  // at the end of the interval. Real-time safe (no allocation, no exceptions).
  double Step(double dt, double x0, double v0, double x1, double v1, double E);

  // Force [N] for displacement x [cm], velocity xdot [cm/s] at the current state.
  double Force(double x, double xdot) const;

  // Pure rates of (y, z, u) and force [N] at an arbitrary state: for integrators that couple
  // the damper with other dynamics in one RK4 step (quarter_car.hpp). Real-time safe.
  SpencerState Derivative(const SpencerState& s, double x, double xdot, double E) const;
  double ForceAt(const SpencerState& at, double x, double xdot) const;

  const SpencerState& state() const { return state_; }
  const SpencerParams& params() const { return params_; }
  int substeps() const { return substeps_; }

 private:
  double Ydot(const SpencerState& s, double x, double xdot) const;

  SpencerParams params_;
  int substeps_;
  SpencerState state_;
};

}  // namespace mrd
