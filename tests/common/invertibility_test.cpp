// The per-state invertibility check (common/include/mrd/common/invertibility.hpp): the
// polynomial in the command against the model evaluated at the command, monotone in the
// dissipative direction, one-to-one, the tolerance, interior extremes of the slope, v = 0, and
// the steady state RegressorHistory::Hold builds.
#include "mrd/common/invertibility.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

namespace mrd {
namespace {

// Channels: 0 = f (output), 1 = E, 2 = v. Regressors: 0 = f, 1 = E, 2 = low-pass E (tau 6),
// 3 = sign(v), 4 = tanh(v / 0.1).
Model Base() {
  Model m;
  m.num_channels = 3;
  m.output_channel = 0;
  std::strcpy(m.channel_names[0].data(), "f");
  std::strcpy(m.channel_names[1].data(), "E");
  std::strcpy(m.channel_names[2].data(), "v");
  m.scales[0] = {0.0, 1500.0};
  m.scales[1] = {0.0, 2.25};
  m.scales[2] = {0.0, 15.0};
  m.num_regressors = 5;
  m.regressors[0] = {0, Transform::kIdentity, 1.0};
  m.regressors[1] = {1, Transform::kIdentity, 1.0};
  m.regressors[2] = {1, Transform::kLowPass, 6.0};
  m.regressors[3] = {2, Transform::kSign, 1.0};
  m.regressors[4] = {2, Transform::kTanh, 0.1};
  return m;
}

void AddTerm(Model* m, double theta, std::initializer_list<Factor> factors) {
  Term& t = m->terms[m->num_terms];
  for (const Factor& f : factors) t.factors[t.num_factors++] = f;
  m->coefficients[m->num_terms++] = theta;
}

// A damper-like model: y = 0.5 y(k-1) + 0.4 E(k) w(k) + 0.2 e(k)^2 w(k) + 0.3 w(k-1)
// (w = tanh(v / 0.1)): the force rises with E in the direction of v.
Model Damper() {
  Model m = Base();
  AddTerm(&m, 0.5, {{0, 1, 1}});
  AddTerm(&m, 0.4, {{1, 0, 1}, {4, 0, 1}});
  AddTerm(&m, 0.2, {{2, 0, 2}, {4, 0, 1}});
  AddTerm(&m, 0.3, {{4, 1, 1}});
  return m;
}

// The state after a short history of (f, E, v) rows, prepared up to sample k's command.
ModelRunner Prepared(const Model& m, double v_now) {
  ModelRunner r(m);
  for (int k = 0; k < 20; ++k) {
    const double row[3] = {300.0 * std::sin(0.3 * k), 1.0 + 0.5 * std::sin(0.2 * k),
                           5.0 * std::sin(0.25 * k)};
    r.Seed(row);
  }
  const double now[3] = {0.0, 0.0, v_now};
  r.Begin(now);
  return r;
}

TEST(InvertibilityTest, PolynomialEqualsTheModelAtEveryCommand) {
  const Model m = Damper();
  ModelRunner r = Prepared(m, 4.0);
  const auto a = InputPolynomial(m, 1, r.history());
  for (const double E : {0.0, 0.3, 1.1, 2.25, 3.0}) {
    r.SetInput(1, E);
    const double e = E / 2.25;
    double y = 0.0;
    for (int j = kMaxInputDegree; j >= 0; --j) y = y * e + a[static_cast<std::size_t>(j)];
    EXPECT_NEAR(Denormalise(m.scales[0], y), r.Evaluate(), 1e-9) << "E = " << E;
  }
  // The terms' polynomials, weighted by their coefficients, add up to the model's.
  std::array<double, kMaxInputDegree + 1> sum{};
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    const auto t = TermInputPolynomial(m, m.terms[i], 1, r.history());
    for (std::size_t j = 0; j < sum.size(); ++j) sum[j] += m.coefficients[i] * t[j];
  }
  for (std::size_t j = 0; j < sum.size(); ++j) EXPECT_EQ(sum[j], a[j]) << j;
}

TEST(InvertibilityTest, DamperLikeModelPassesInBothDirections) {
  const Model m = Damper();
  const InvertibilityLimits lim{0.0, 2.25, DefaultSlopeTolerance(1500.0, 0.0, 2.25)};
  for (const double v : {6.0, -6.0, 0.5, -0.5}) {
    ModelRunner r = Prepared(m, v);
    const StateInvertibility s = CheckStateInvertibility(m, 1, r.history(), v, lim);
    EXPECT_TRUE(s.monotone) << v;
    EXPECT_TRUE(s.one_to_one) << v;
    EXPECT_GT(s.worst_slope, 0.0) << v;  // rises with E in the direction of v
  }
}

TEST(InvertibilityTest, ForceFallingWithTheCommandFailsAndNamesWhere) {
  Model m = Damper();
  m.coefficients[1] = -0.4;  // E(k) w(k): the force now falls as E rises ...
  m.coefficients[2] = 0.0;
  const InvertibilityLimits lim{0.0, 2.25, DefaultSlopeTolerance(1500.0, 0.0, 2.25)};
  ModelRunner r = Prepared(m, 6.0);
  const StateInvertibility s = CheckStateInvertibility(m, 1, r.history(), 6.0, lim);
  EXPECT_FALSE(s.monotone);
  EXPECT_TRUE(s.one_to_one);  // ... but stays one-to-one (a straight line)
  // df/dE = -0.4 tanh(6 / 1.5) 1500 / 2.25 N/V everywhere.
  EXPECT_NEAR(s.worst_slope, -0.4 * std::tanh(4.0) * 1500.0 / 2.25, 1e-9);
  // At v = 0 there is no dissipative direction: monotone holds, the slope is 0 (tanh(0)).
  ModelRunner rest = Prepared(m, 0.0);
  EXPECT_TRUE(CheckStateInvertibility(m, 1, rest.history(), 0.0, lim).ok());
}

TEST(InvertibilityTest, SlopeTurningInsideTheRangeIsNotOneToOne) {
  // y(e) = e - 2 e^2 on e in [0, 1]: slope 1 at 0, -3 at 1, a maximum at e = 0.25 inside.
  const std::array<double, kMaxInputDegree + 1> a{0.0, 1.0, -2.0, 0.0, 0.0};
  const BasicChannelScale<double> unit{0.0, 1.0};
  const InvertibilityLimits lim{0.0, 1.0, 0.01};
  const StateInvertibility s = CheckInputPolynomial(a, unit, unit, 1, lim);
  EXPECT_FALSE(s.one_to_one);
  EXPECT_FALSE(s.monotone);
  EXPECT_DOUBLE_EQ(s.min_slope, -3.0);
  EXPECT_DOUBLE_EQ(s.max_slope, 1.0);
  EXPECT_DOUBLE_EQ(s.worst_e, 1.0);
  // Negative velocity: the same slope read in the other direction, still not one-to-one.
  const StateInvertibility n = CheckInputPolynomial(a, unit, unit, -1, lim);
  EXPECT_FALSE(n.monotone);
  EXPECT_DOUBLE_EQ(n.worst_slope, -1.0);
  EXPECT_DOUBLE_EQ(n.worst_e, 0.0);
}

TEST(InvertibilityTest, DipOfTheSlopeBetweenTheEndsIsFound) {
  // y' = 3 (e - 0.5)^2 - 0.03: positive at both ends of [0, 1], -0.03 at e = 0.5.
  // y = (e - 0.5)^3 - 0.03 e = e^3 - 1.5 e^2 + 0.72 e - 0.125.
  const std::array<double, kMaxInputDegree + 1> a{-0.125, 0.72, -1.5, 1.0, 0.0};
  const BasicChannelScale<double> unit{0.0, 1.0};
  const StateInvertibility tight = CheckInputPolynomial(a, unit, unit, 1, {0.0, 1.0, 0.001});
  EXPECT_FALSE(tight.monotone);
  EXPECT_NEAR(tight.worst_slope, -0.03, 1e-12);
  EXPECT_NEAR(tight.worst_e, 0.5, 1e-12);
  // Within the tolerance the dip counts as flat.
  EXPECT_TRUE(CheckInputPolynomial(a, unit, unit, 1, {0.0, 1.0, 0.05}).ok());
  // The range that leaves the dip out passes.
  EXPECT_TRUE(CheckInputPolynomial(a, unit, unit, 1, {0.0, 0.3, 0.001}).ok());
}

TEST(InvertibilityTest, QuarticSlopeLowestAtAnInteriorRoot) {
  // y = -e^4 + 2 e^3 - 1.2 e^2 + 0.5 e on [0, 0.6]: y' = -4 e^3 + 6 e^2 - 2.4 e + 0.5 is 0.5
  // and 0.356 at the ends and lowest at the root e0 = 0.5 - sqrt(0.05) of y'' = -12 e^2 + 12 e
  // - 2.4 inside (the other root, 0.5 + sqrt(0.05), lies beyond the range).
  const std::array<double, kMaxInputDegree + 1> a{0.0, 0.5, -1.2, 2.0, -1.0};
  const BasicChannelScale<double> unit{0.0, 1.0};
  const StateInvertibility s = CheckInputPolynomial(a, unit, unit, 1, {0.0, 0.6, 0.0});
  const double e0 = 0.5 - std::sqrt(0.05);
  const double lowest = -4 * e0 * e0 * e0 + 6 * e0 * e0 - 2.4 * e0 + 0.5;
  EXPECT_NEAR(s.worst_slope, lowest, 1e-12);
  EXPECT_NEAR(s.worst_e, e0, 1e-12);
  EXPECT_NEAR(s.max_slope, 0.5, 1e-12);
  EXPECT_TRUE(s.ok());
  // Lowered by 0.25 the slope dips below 0 there only: monotone fails, and with a rise at e = 0
  // it is not one-to-one either.
  const std::array<double, kMaxInputDegree + 1> b{0.0, 0.25, -1.2, 2.0, -1.0};
  const StateInvertibility t = CheckInputPolynomial(b, unit, unit, 1, {0.0, 0.6, 0.0});
  EXPECT_FALSE(t.monotone);
  EXPECT_FALSE(t.one_to_one);
}

TEST(InvertibilityTest, NonFiniteStateFails) {
  const std::array<double, kMaxInputDegree + 1> a{0.0, std::nan(""), 0.0, 0.0, 0.0};
  const BasicChannelScale<double> unit{0.0, 1.0};
  const StateInvertibility s = CheckInputPolynomial(a, unit, unit, 1, {0.0, 1.0, 0.01});
  EXPECT_FALSE(s.monotone);
  EXPECT_FALSE(s.one_to_one);
}

TEST(InvertibilityTest, HoldIsTheSteadyStateOfConstantInputs) {
  const Model m = Damper();
  const double raw[3] = {250.0, 1.5, 3.0};
  double norm[3];
  for (int c = 0; c < 3; ++c) norm[c] = Normalise(m.scales[c], raw[c]);
  RegressorHistory held;
  held.Reset(m);
  held.Hold(m, norm);
  // The same state reached by holding the inputs long enough (the low-pass settles).
  ModelRunner r(m);
  for (int k = 0; k < 2000; ++k) r.Seed(raw);
  for (std::size_t reg = 0; reg < m.num_regressors; ++reg) {
    for (std::size_t d = 0; d <= kMaxDelay; ++d) {
      EXPECT_NEAR(held.value(reg, d), r.history().value(reg, d), 1e-12) << reg << " " << d;
    }
  }
}

TEST(InvertibilityTest, DefaultToleranceIsAShareOfTheForceOverTheRange) {
  EXPECT_DOUBLE_EQ(DefaultSlopeTolerance(1500.0, 0.0, 2.5), kFlatForceShare * 1500.0 / 2.5);
  EXPECT_EQ(DefaultSlopeTolerance(1500.0, 2.0, 2.0), 0.0);
  EXPECT_EQ(DefaultSlopeTolerance(1500.0, 0.0, std::nan("")), 0.0);
}

}  // namespace
}  // namespace mrd
