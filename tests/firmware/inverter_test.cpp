#include "mrd/firmware/inverter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mrd/firmware/model_runtime.hpp"
#include "reference_models.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

// The inversion algorithm at T = double, with exact-arithmetic tolerances, in every build; the
// float instantiation (MRD_REAL=float) against it: tests/integration/float_accuracy_test.cpp.
using ModelRuntime = BasicModelRuntime<double>;
using Inverter = BasicInverter<double>;
using PolyRoots = BasicPolyRoots<double>;

struct Fixture {
  explicit Fixture(const CoefficientTable& t) {
    EXPECT_EQ(runtime.Configure(t), Error::kOk);
    EXPECT_EQ(inverter.Configure(t), Error::kOk);
  }
  // Drives the model through a random history, then begins a sample at velocity v.
  void RandomState(std::mt19937& rng) {
    std::uniform_real_distribution<double> vel(-15.0, 15.0), volt(0.0, 2.25);
    runtime.Reset();
    for (int k = 0; k < 20; ++k) runtime.Step(vel(rng), 0.0, volt(rng));
    v = vel(rng);
    runtime.Begin(v, 0.0);
  }
  ModelRuntime runtime;
  Inverter inverter;
  double v = 0.0;  // the state's velocity [cm/s]
};

double RelErr(double a, double b) { return std::fabs(a - b) / std::max(1.0, std::fabs(b)); }

void RoundTrip(const CoefficientTable& table) {
  Fixture fx(table);
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> volt(0.0, 2.25);
  double worst = 0.0;
  for (int trial = 0; trial < 2000; ++trial) {
    fx.RandomState(rng);
    const double f = fx.runtime.ForceAt(volt(rng));  // reachable by construction
    // Velocity 0: no dissipative direction, the demand is inverted as it is.
    const auto s = fx.inverter.Solve(fx.runtime.history(), f, 0.0);
    EXPECT_TRUE(s.reachable) << "trial " << trial;
    EXPECT_GE(s.E, 0.0);
    EXPECT_LE(s.E, 2.25);
    worst = std::max(worst, RelErr(fx.runtime.ForceAt(s.E), f));
    EXPECT_NEAR(s.force, fx.runtime.ForceAt(s.E), 1e-9 * std::max(1.0, std::fabs(f)));
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(InverterTest, RoundTripOnReachableDemandsDemoModel) { RoundTrip(test::DemoDamperTable()); }

TEST(InverterTest, RoundTripOnReachableDemandsQuarticModel) { RoundTrip(test::QuarticTable()); }

TEST(InverterTest, RoundTripOnReachableDemandsLowPassModel) { RoundTrip(test::LowPassTable()); }

TEST(InverterTest, LowPassInputIsExpandedAsAffineInE) {
  Fixture fx(test::LowPassTable());
  EXPECT_EQ(fx.inverter.degree(), 4);
  std::mt19937 rng(11);
  fx.RandomState(rng);
  // The polynomial reproduces the model at five commands (it is exact, not a fit).
  const auto a = fx.inverter.Polynomial(fx.runtime.history());
  for (double E : {0.0, 0.4, 1.1, 1.9, 2.25}) {
    const double e = E / 2.25;
    double y = 0.0;
    for (int j = 4; j >= 0; --j) y = y * e + a[static_cast<std::size_t>(j)];
    EXPECT_NEAR(1500.0 * y, fx.runtime.ForceAt(E), 1e-9 * 1500.0) << "E " << E;
  }
}

TEST(InverterTest, AgreesWithDenseSearch) {
  for (const CoefficientTable& table :
       {test::DemoDamperTable(), test::QuarticTable(), test::LowPassTable()}) {
    Fixture fx(table);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> demand(-2500.0, 2500.0);
    for (int trial = 0; trial < 200; ++trial) {
      fx.RandomState(rng);
      const double f = demand(rng);
      // Velocity 0: the nearest force as it is (the semi-active rules at v != 0:
      // inversion_semantics_test.cpp).
      const auto s = fx.inverter.Solve(fx.runtime.history(), f, 0.0);
      double best = std::numeric_limits<double>::infinity();
      constexpr int kGrid = 20000;
      for (int i = 0; i <= kGrid; ++i) {
        best = std::min(best, std::fabs(fx.runtime.ForceAt(2.25 * i / kGrid) - f));
      }
      const double got = std::fabs(fx.runtime.ForceAt(s.E) - f);
      EXPECT_LE(got, best + 1e-9 * std::max(1.0, std::fabs(f))) << "trial " << trial;
    }
  }
}

TEST(InverterTest, UnreachableDemandsSaturateToTheRightBound) {
  Fixture fx(test::MonotoneTable());
  std::mt19937 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    fx.RandomState(rng);
    const double f_lo = fx.runtime.ForceAt(0.0), f_hi = fx.runtime.ForceAt(2.25);
    const double top = std::max(f_lo, f_hi), bottom = std::min(f_lo, f_hi);
    // A demand against v is passive (E_min), which is where the saturation points too.
    const auto above = fx.inverter.Solve(fx.runtime.history(), top + 500.0, fx.v);
    const auto below = fx.inverter.Solve(fx.runtime.history(), bottom - 500.0, fx.v);
    EXPECT_FALSE(above.reachable);
    EXPECT_FALSE(below.reachable);
    EXPECT_EQ(above.E, f_hi > f_lo ? 2.25 : 0.0) << "trial " << trial;
    EXPECT_EQ(below.E, f_hi > f_lo ? 0.0 : 2.25) << "trial " << trial;
  }
}

TEST(InverterTest, NarrowedRangeIsRespected) {
  Fixture fx(test::DemoDamperTable());
  ASSERT_EQ(fx.inverter.SetRange(0.0, 1.5), Error::kOk);
  EXPECT_EQ(fx.inverter.SetRange(0.0, 3.0), Error::kOutOfRange);
  fx.runtime.Begin(10.0, 0.0);
  const auto s = fx.inverter.Solve(fx.runtime.history(), 1e6, 10.0);
  EXPECT_EQ(s.E, 1.5);
}

TEST(InverterTest, RefusesNonIdentityInputAtDelayZero) {
  CoefficientTable t = test::DemoDamperTable();
  Model& m = t.model;
  m.regressors[m.num_regressors++] = {1, Transform::kAbsPow, 0.5};  // |E|^0.5
  test::AddTerm(t, {{5, 0, 1}}, 0.1);
  Inverter inv;
  EXPECT_EQ(inv.Configure(t), Error::kNotInvertible);
  // The same regressor at delay 1 is history, hence fine.
  t.model.terms[t.model.num_terms - 1].factors[0].delay = 1;
  EXPECT_EQ(inv.Configure(t), Error::kOk);
}

TEST(InverterTest, RefusesDegreeAboveFour) {
  CoefficientTable t = test::QuarticTable();
  test::AddTerm(t, {{1, 0, 3}, {1, 0, 2}}, 0.01);
  Inverter inv;
  EXPECT_EQ(inv.Configure(t), Error::kNotInvertible);
}

TEST(InverterTest, RefusesModelWithoutTheInput) {
  CoefficientTable t = test::EmptyTable();
  test::AddTerm(t, {{0, 1, 1}}, 0.5);
  test::AddTerm(t, {{1, 1, 1}}, 0.5);  // E(k-1) only
  Inverter inv;
  EXPECT_EQ(inv.Configure(t), Error::kNotInvertible);
}

TEST(InverterTest, InputWithoutEffectInThisStateGivesTheLowestCommand) {
  CoefficientTable t = test::EmptyTable();
  test::AddTerm(t, {{1, 0, 1}, {3, 0, 1}}, 0.5);  // E sign(v): no effect at v == 0
  Fixture fx(t);
  fx.runtime.Begin(0.0, 0.0);
  const auto s = fx.inverter.Solve(fx.runtime.history(), 100.0, 0.0);
  EXPECT_EQ(s.E, 0.0);
  EXPECT_FALSE(s.reachable);
  EXPECT_FALSE(s.passive);
  EXPECT_TRUE(s.monotone);
}

TEST(InverterTest, TinyLeadingCoefficientBehavesLikeLowerDegree) {
  CoefficientTable t = test::EmptyTable();
  test::AddTerm(t, {}, -0.3);
  test::AddTerm(t, {{1, 0, 1}}, 0.6);
  test::AddTerm(t, {{1, 0, 4}}, 1e-300);
  Fixture fx(t);
  fx.runtime.Begin(1.0, 0.0);
  // y(e) = -0.3 + 0.6 e: the demand y = -0.1 (-150 N) at e = 1/3.
  const auto s = fx.inverter.Solve(fx.runtime.history(), -150.0, 0.0);
  EXPECT_TRUE(s.reachable);
  EXPECT_NEAR(s.E, 2.25 / 3.0, 1e-12);
}

// y(e) = (e - 0.5)^2 + 0.1: the demand y = 0.1 (150 N) is a touching (double) root inside the
// range.
TEST(InverterTest, FindsDoubleRoot) {
  CoefficientTable t = test::EmptyTable();
  test::AddTerm(t, {}, 0.35);
  test::AddTerm(t, {{1, 0, 1}}, -1.0);
  test::AddTerm(t, {{1, 0, 2}}, 1.0);
  Fixture fx(t);
  fx.runtime.Begin(1.0, 0.0);
  const auto s = fx.inverter.Solve(fx.runtime.history(), 150.0, 0.0);
  EXPECT_TRUE(s.reachable);
  // The rounded demand may split the double root into two a few 1e-9 apart (a double root is
  // determined to ~sqrt(eps)); the lower one is taken.
  EXPECT_NEAR(s.E, 0.5 * 2.25, 1e-7);
  EXPECT_NEAR(fx.runtime.ForceAt(s.E), 150.0, 1e-9);
  EXPECT_FALSE(s.monotone);
  // Slightly below the minimum: unreachable, the extremum is the closest force.
  const auto u = fx.inverter.Solve(fx.runtime.history(), 149.0, 0.0);
  EXPECT_FALSE(u.reachable);
  EXPECT_NEAR(u.E, 0.5 * 2.25, 1e-9);
}

// y(e) = (e - 0.5)^3 + 0.1: a triple root at the demand y = 0.1 (150 N); monotone.
TEST(InverterTest, FindsTripleRoot) {
  CoefficientTable t = test::EmptyTable();
  test::AddTerm(t, {}, -0.025);
  test::AddTerm(t, {{1, 0, 1}}, 0.75);
  test::AddTerm(t, {{1, 0, 2}}, -1.5);
  test::AddTerm(t, {{1, 0, 3}}, 1.0);
  Fixture fx(t);
  fx.runtime.Begin(1.0, 0.0);
  const auto s = fx.inverter.Solve(fx.runtime.history(), 150.0, 1.0);
  EXPECT_TRUE(s.monotone);
  EXPECT_NEAR(fx.runtime.ForceAt(s.E), 150.0, 1e-6);
  EXPECT_NEAR(s.E, 0.5 * 2.25, 1e-4);  // a triple root is determined to ~cbrt(eps)
}

// y(e) = (e - 0.2)(e - 0.8) + 0.1: two admissible roots at y = 0.1 (150 N); the lowest wins.
TEST(InverterTest, PicksTheLowestRoot) {
  CoefficientTable t = test::EmptyTable();
  test::AddTerm(t, {}, 0.26);
  test::AddTerm(t, {{1, 0, 1}}, -1.0);
  test::AddTerm(t, {{1, 0, 2}}, 1.0);
  Fixture fx(t);
  fx.runtime.Begin(1.0, 0.0);
  const auto s = fx.inverter.Solve(fx.runtime.history(), 150.0, 0.0);
  EXPECT_TRUE(s.reachable);
  EXPECT_NEAR(s.E, 0.2 * 2.25, 1e-12);
  // Above the force at both ends (390 N at 0 V and at 2.25 V): the tie goes to 0 V.
  EXPECT_EQ(fx.inverter.Solve(fx.runtime.history(), 500.0, 0.0).E, 0.0);
  // At v > 0 the dip is not used: 150 N is below the 390 N of 0 V, which is the command.
  const auto d = fx.inverter.Solve(fx.runtime.history(), 150.0, 1.0);
  EXPECT_EQ(d.E, 0.0);
  EXPECT_FALSE(d.reachable);
}

TEST(RealRootsTest, FindsAllFourRootsOfAQuartic) {
  // (x - 0.1)(x - 0.3)(x + 0.5)(x - 0.9) = x^4 - 0.8x^3 - 0.26x^2 + 0.168x - 0.0135
  const std::array<double, 5> a = {-0.0135, 0.168, -0.26, -0.8, 1.0};
  const PolyRoots r = RealRootsInInterval<double>(a, 4, -1.0, 1.0);
  ASSERT_EQ(r.num_roots, 4);
  EXPECT_NEAR(r.roots[0], -0.5, 1e-14);
  EXPECT_NEAR(r.roots[1], 0.1, 1e-14);
  EXPECT_NEAR(r.roots[2], 0.3, 1e-14);
  EXPECT_NEAR(r.roots[3], 0.9, 1e-14);
  EXPECT_EQ(r.num_critical, 3);
  const PolyRoots half = RealRootsInInterval<double>(a, 4, 0.0, 0.5);
  EXPECT_EQ(half.num_roots, 2);
}

}  // namespace
}  // namespace mrd::firmware
