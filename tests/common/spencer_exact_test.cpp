// The reference damper tied to exact values of its equations (spencer_damper.hpp), for both
// presets: forces after Reset worked out by hand, and one RK4 step against an independent
// implementation of the classical scheme.
#include <gtest/gtest.h>

#include <cmath>

#include "mrd/sim/spencer_damper.hpp"

namespace mrd {
namespace {

// Relative tolerance for values computed by hand in double precision.
constexpr double kRel = 1e-12;

TEST(SpencerExactTest, StaticForceAfterResetIsTheAccumulatorSpring) {
  // At rest with y = x, z = 0: ydot = 0, so f = k1 (x - x0).
  SpencerDamper paper(SpencerParams::Paper());
  paper.Reset(2.0, 1.0);
  EXPECT_NEAR(paper.Force(2.0, 0.0), 10.74, kRel * 10.74);  // 5.37 * (2 - 0)
  SpencerDamper s97(SpencerParams::Spencer1997());
  s97.Reset(2.0, 1.0);
  EXPECT_NEAR(s97.Force(2.0, 0.0), -61.5, kRel * 61.5);  // 5.0 * (2 - 14.3)
}

TEST(SpencerExactTest, DisplacedFromInternalStateAddsTheK0Spring) {
  // Reset at x = 2 (y = 2, z = 0, u = 1 V), evaluated at x = 3, xdot = 0:
  //   ydot = k0 (3 - 2) / (c0 + c1),  f = c1 ydot + k1 (3 - x0).
  // paper:       c0 = 22.88, c1 = 420.7:  f = 420.7 * 15 / 443.58 + 16.11
  // spencer1997: c0 = 24.5, c1 = 285.95:  f = 285.95 * 46.9 / 310.45 - 56.5
  SpencerDamper paper(SpencerParams::Paper());
  paper.Reset(2.0, 1.0);
  EXPECT_NEAR(paper.Force(3.0, 0.0), 30.336295144055185, kRel * 30.3);
  SpencerDamper s97(SpencerParams::Spencer1997());
  s97.Reset(2.0, 1.0);
  EXPECT_NEAR(s97.Force(3.0, 0.0), -13.301240135287486, kRel * 13.3);
}

TEST(SpencerExactTest, MovingForceAddsTheC0ViscousTerm) {
  // As above with xdot = 4 cm/s: ydot = (c0 * 4 + k0 (3 - 2)) / (c0 + c1).
  SpencerDamper paper(SpencerParams::Paper());
  paper.Reset(2.0, 1.0);
  EXPECT_NEAR(paper.Force(3.0, 4.0), 117.13566391631723, kRel * 117.0);
  SpencerDamper s97(SpencerParams::Spencer1997());
  s97.Reset(2.0, 1.0);
  EXPECT_NEAR(s97.Force(3.0, 4.0), 76.96482525366403, kRel * 77.0);
}

// The model's right-hand side written out from the header's equations, independently of the
// class: d/dt (y, z, u).
SpencerState Rhs(const SpencerParams& p, const SpencerState& s, double x, double xdot, double E) {
  const double alpha = p.alpha_a + p.alpha_b * s.u;
  const double c0 = p.c0a + p.c0b * s.u;
  const double c1 = p.c1a + p.c1b * s.u;
  const double ydot = (alpha * s.z + c0 * xdot + p.k0 * (x - s.y)) / (c0 + c1);
  const double dv = xdot - ydot;
  const double zdot = -p.gamma * std::fabs(dv) * s.z * std::pow(std::fabs(s.z), p.n - 1.0) -
                      p.beta * dv * std::pow(std::fabs(s.z), p.n) + p.A * dv;
  return {ydot, zdot, -p.eta * (s.u - E)};
}

// One classical RK4 step of size h along x(t) = xa + v t (a Hermite interpolant of a linear
// motion is that line).
SpencerState Rk4(const SpencerParams& p, const SpencerState& s, double h, double xa, double v,
                 double E) {
  auto add = [](const SpencerState& a, double c, const SpencerState& d) {
    return SpencerState{a.y + c * d.y, a.z + c * d.z, a.u + c * d.u};
  };
  const SpencerState k1 = Rhs(p, s, xa, v, E);
  const SpencerState k2 = Rhs(p, add(s, h / 2, k1), xa + v * h / 2, v, E);
  const SpencerState k3 = Rhs(p, add(s, h / 2, k2), xa + v * h / 2, v, E);
  const SpencerState k4 = Rhs(p, add(s, h, k3), xa + v * h, v, E);
  return {s.y + h / 6 * (k1.y + 2 * k2.y + 2 * k3.y + k4.y),
          s.z + h / 6 * (k1.z + 2 * k2.z + 2 * k3.z + k4.z),
          s.u + h / 6 * (k1.u + 2 * k2.u + 2 * k3.u + k4.u)};
}

void ExpectOneSubstepIsClassicalRk4(const SpencerParams& p) {
  constexpr double kH = 1e-3;  // [s], one substep per interval
  constexpr double kV = 12.0;  // [cm/s]
  SpencerDamper d(p, 1);
  d.Reset(0.5, 0.2);
  SpencerState ref{0.5, 0.0, 0.2};
  double x = 0.5;
  // Three steps with a voltage step: z, u and y all move, so every stage matters.
  for (int i = 0; i < 3; ++i) {
    const double E = 1.8;
    const double f = d.Step(kH, x, kV, x + kV * kH, kV, E);
    ref = Rk4(p, ref, kH, x, kV, E);
    x += kV * kH;
    EXPECT_NEAR(d.state().y, ref.y, 1e-12 * std::fabs(ref.y)) << "step " << i;
    EXPECT_NEAR(d.state().z, ref.z, 1e-12 * std::fabs(ref.z)) << "step " << i;
    EXPECT_NEAR(d.state().u, ref.u, 1e-12 * std::fabs(ref.u)) << "step " << i;
    const double c1 = p.c1a + p.c1b * ref.u;
    const double ydot = Rhs(p, ref, x, kV, E).y;
    const double f_ref = c1 * ydot + p.k1 * (x - p.x0);
    EXPECT_NEAR(f, f_ref, 1e-10 * std::fabs(f_ref)) << "step " << i;
  }
  EXPECT_GT(std::fabs(ref.z), 1e-3);  // the hysteretic state did move
}

TEST(SpencerExactTest, OneSubstepIsClassicalRk4PaperPreset) {
  ExpectOneSubstepIsClassicalRk4(SpencerParams::Paper());
}

TEST(SpencerExactTest, OneSubstepIsClassicalRk4Spencer1997Preset) {
  ExpectOneSubstepIsClassicalRk4(SpencerParams::Spencer1997());
}

TEST(SpencerExactTest, VoltageFilterStepIsTheRk4PolynomialOfEtaH) {
  // At rest, u' = -eta (u - E) alone: one RK4 step multiplies (u - E) by
  // 1 - q + q^2/2 - q^3/6 + q^4/24, q = eta h.
  const SpencerParams p = SpencerParams::Paper();
  constexpr double kH = 2e-3;
  SpencerDamper d(p, 1);
  d.Reset(0.0, 0.0);
  d.Step(kH, 0.0, 0.0, 0.0, 0.0, 2.0);
  const double q = p.eta * kH;
  const double g = 1 - q + q * q / 2 - q * q * q / 6 + q * q * q * q / 24;
  EXPECT_NEAR(d.state().u, 2.0 - 2.0 * g, 1e-14);
}

}  // namespace
}  // namespace mrd
