// The envelope's margin (model_runtime.hpp): the model's v and x, and the force fed back, are
// held to [min - m, max + m], m = margin * (max - min), the identification data's range
// widened by the margin on BOTH sides. Values between the data's edge and the widened bound
// pass unchanged, values beyond are held exactly at the bound, a value at the bound is no
// excursion; the margin is a fraction of the range (not of |max|), and the controller hands
// its configured margin to the runtime at Configure and at every Retune.
#include <gtest/gtest.h>

#include <cstddef>

#include "mrd/common/table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "support/fev_table.hpp"

namespace mrd::firmware {
namespace {

// Data ranges, asymmetric so that a margin of the range differs from one of |max| and the two
// sides differ: v [-10, 20] cm/s (range 30), x [-1, 2] cm (range 3), f [-800, 1000] N (range
// 1800), E [0, 2.25] V.
constexpr double kVMin = -10.0, kVMax = 20.0, kXMin = -1.0, kXMax = 2.0;
constexpr double kFMin = -800.0, kFMax = 1000.0;

// f(k) = 1000 N * (v(k) / 15 + 0.01 x(k) / 3 + 0.01 E(k) / 2.25): no history, so every step's
// force follows its own (held) inputs: 66.7 N per cm/s of velocity.
CoefficientTable MarginTable() {
  CoefficientTable t = test::FevTableSkeleton();
  Model& m = t.model;
  m.num_channels = 4;
  m.channel_names[3] = {'x'};
  m.scales[3] = {0.0, 3.0};
  m.num_regressors = 3;
  m.regressors[0] = {2, Transform::kIdentity, 1.0};  // v
  m.regressors[1] = {3, Transform::kIdentity, 1.0};  // x
  m.regressors[2] = {1, Transform::kIdentity, 1.0};  // E
  m.num_terms = 3;
  const double theta[] = {1.0, 0.01, 0.01};
  for (std::size_t i = 0; i < 3; ++i) {
    m.terms[i].num_factors = 1;
    m.terms[i].factors[0] = {static_cast<std::uint8_t>(i), 0, 1};
    m.coefficients[i] = theta[i];
  }
  t.has_envelope = true;
  t.envelope[0] = {kFMin, kFMax};
  t.envelope[1] = {0.0, 2.25};
  t.envelope[2] = {kVMin, kVMax};
  t.envelope[3] = {kXMin, kXMax};
  return t;
}

// The widened bounds as documented, for margin `margin`.
double Lo(double min, double max, double margin) { return min - margin * (max - min); }
double Hi(double min, double max, double margin) { return max + margin * (max - min); }

struct Runtime {
  explicit Runtime(double margin) {
    EXPECT_EQ(rt.Configure(MarginTable()), Error::kOk);
    EXPECT_EQ(rt.SetEnvelope(true, margin), Error::kOk);
    EXPECT_TRUE(rt.envelope_active());
  }
  BasicModelRuntime<double> rt;
};

TEST(EnvelopeMarginTest, BetweenTheDataEdgeAndTheWidenedBoundInputsPassUnchanged) {
  Runtime r(0.1);  // v [-13, 23], x [-1.3, 2.3]
  const double vs[] = {-12.5, -10.5, 20.5, 22.5};
  const double xs[] = {-1.25, -1.05, 2.05, 2.25};
  for (std::size_t i = 0; i < 4; ++i) {
    r.rt.Begin(vs[i], xs[i]);
    EXPECT_EQ(r.rt.held_v(), vs[i]) << i;
    EXPECT_EQ(r.rt.held_x(), xs[i]) << i;
    (void)r.rt.Finish(1.0);
  }
  EXPECT_EQ(r.rt.input_excursions(), 0u);
}

TEST(EnvelopeMarginTest, BeyondTheWidenedBoundInputsAreHeldExactlyAtIt) {
  Runtime r(0.1);
  r.rt.Begin(-14.0, -2.0);
  EXPECT_EQ(r.rt.held_v(), Lo(kVMin, kVMax, 0.1));  // -13
  EXPECT_EQ(r.rt.held_x(), Lo(kXMin, kXMax, 0.1));  // -1.3
  (void)r.rt.Finish(1.0);
  r.rt.Begin(24.0, 3.0);
  EXPECT_EQ(r.rt.held_v(), Hi(kVMin, kVMax, 0.1));  // 23
  EXPECT_EQ(r.rt.held_x(), Hi(kXMin, kXMax, 0.1));  // 2.3
  (void)r.rt.Finish(1.0);
  EXPECT_EQ(r.rt.input_excursions(), 2u);  // one per sample, however many inputs were held
  // Exactly at the bounds: no excursion.
  r.rt.ClearExcursions();
  r.rt.Begin(Lo(kVMin, kVMax, 0.1), Hi(kXMin, kXMax, 0.1));
  (void)r.rt.Finish(1.0);
  r.rt.Begin(Hi(kVMin, kVMax, 0.1), Lo(kXMin, kXMax, 0.1));
  (void)r.rt.Finish(1.0);
  EXPECT_EQ(r.rt.input_excursions(), 0u);
}

TEST(EnvelopeMarginTest, TheFedBackForceIsHeldToItsWidenedEnvelope) {
  Runtime r(0.1);  // f [-980, 1180] N
  // v = -12.5 cm/s: about -833 N, below the data's -800 N but inside the margin: unchanged.
  r.rt.Begin(-12.5, 0.0);
  const double low = r.rt.Finish(0.0);
  EXPECT_NEAR(low, -1000.0 * 12.5 / 15.0, 1e-9);
  // v = 19 cm/s: about 1267 N, beyond 1180 N: held at the bound, counted.
  r.rt.Begin(19.0, 0.0);
  EXPECT_EQ(r.rt.Finish(0.0), Hi(kFMin, kFMax, 0.1));
  EXPECT_EQ(r.rt.force_excursions(), 1u);
  // v = -14.7 cm/s: the velocity is held at -13 (about -867 N): inside, not a force excursion.
  r.rt.Begin(-14.7, 0.0);
  EXPECT_NEAR(r.rt.Finish(0.0), -1000.0 * 13.0 / 15.0, 1e-9);
  EXPECT_EQ(r.rt.force_excursions(), 1u);
}

TEST(EnvelopeMarginTest, TheMarginIsAFractionOfTheRangeAndFollowsSetEnvelope) {
  Runtime r(0.5);  // v [-25, 35]: 0.5 * 30 on each side (0.5 * |max| would give [-20, 30])
  r.rt.Begin(-24.0, 0.0);
  EXPECT_EQ(r.rt.held_v(), -24.0);
  r.rt.Begin(34.0, 0.0);
  EXPECT_EQ(r.rt.held_v(), 34.0);
  r.rt.Begin(-40.0, 0.0);
  EXPECT_EQ(r.rt.held_v(), -25.0);
  // Margin 0: the data's own range.
  ASSERT_EQ(r.rt.SetEnvelope(true, 0.0), Error::kOk);
  r.rt.Begin(-10.5, 2.5);
  EXPECT_EQ(r.rt.held_v(), kVMin);
  EXPECT_EQ(r.rt.held_x(), kXMax);
}

// One controller period at velocity v [cm/s], x [cm] (fresh samples); v as the model got it.
double VUsed(Controller& c, double v, double x) {
  SensorFrame f;
  f[Input::kVelocity] = {v, 1'000'000};
  f[Input::kDisplacement] = {x, 1'000'000};
  (void)c.Update(f, IoStatus::kOk, false, 1'000'000, 1e-3);
  return c.v_used();
}

TEST(EnvelopeMarginTest, TheControllerHandsItsMarginToTheModelAtConfigureAndRetune) {
  ControllerConfig cfg;
  cfg.law.mode = ControlMode::kConstantVoltage;
  cfg.law.constant_voltage = 1.0;
  cfg.envelope_margin = 0.5;  // v [-25, 35]
  Controller c;
  ASSERT_EQ(c.Configure(MarginTable(), cfg), Error::kOk);
  EXPECT_EQ(VUsed(c, -24.0, 0.0), -24.0);
  EXPECT_EQ(VUsed(c, -40.0, 0.0), -25.0);
  cfg.envelope_margin = 0.2;  // v [-16, 26]
  ASSERT_EQ(c.Retune(cfg), Error::kOk);
  EXPECT_EQ(VUsed(c, -15.5, 0.0), -15.5);
  EXPECT_EQ(VUsed(c, -24.0, 0.0), -16.0);
  EXPECT_EQ(VUsed(c, 30.0, 0.0), 26.0);
}

}  // namespace
}  // namespace mrd::firmware
