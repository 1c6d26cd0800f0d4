// Modal skyhook (modal_skyhook.hpp): the least-squares rates of pure heave, pitch and roll
// motions, their forces and moments on the body, the signs (full_car.hpp's axes, the damper
// convention of control_law.hpp), the per-corner skyhook equivalence in heave, refusal of bad
// geometry, and four Controllers on kForceTracking fed by it without an allocation.
#include "mrd/firmware/modal_skyhook.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "mrd/firmware/controller.hpp"
// GCC 12 takes the counting delete's free() for a mismatch with the counting new: a false
// positive, silenced as in no_alloc_test.cpp.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include "support/alloc_counter.hpp"  // replaces the allocator of this executable
#pragma GCC diagnostic pop
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

// An asymmetric car: a != b, front and rear tracks apart, motion ratio 0.7.
BodyGeometry Car() {
  BodyGeometry g;
  g.cg_to_front_m = 1.1;
  g.cg_to_rear_m = 1.5;
  g.track_front_m = 1.6;
  g.track_rear_m = 1.4;
  g.motion_ratio = 0.7;
  return g;
}

double X(const BodyGeometry& g, int i) { return i < 2 ? g.cg_to_front_m : -g.cg_to_rear_m; }
double Y(const BodyGeometry& g, int i) {
  const double t = i < 2 ? g.track_front_m : g.track_rear_m;
  return i % 2 == 0 ? t / 2 : -t / 2;
}

// Corner body velocities [cm/s] of a rigid body moving with heave z' [m/s], pitch theta' and
// roll phi' [rad/s] (full_car.hpp: zb_i = z + x_i theta + y_i phi).
void Corners(const BodyGeometry& g, double z, double th, double ph, double* vb_cm_s) {
  for (int i = 0; i < 4; ++i) vb_cm_s[i] = 100.0 * (z + X(g, i) * th + Y(g, i) * ph);
}

ModalSkyhook Configured(const BodyGeometry& g, const ModalGains& k) {
  ModalSkyhook m;
  EXPECT_EQ(m.Configure(g, k), Error::kOk);
  return m;
}

// Force and moments on the body [N, N m] from damper demands f_i: each pulls the body down
// r-fold (u_i = -r f_i up).
void OnBody(const BodyGeometry& g, const double* f, double* heave, double* pitch, double* roll) {
  *heave = *pitch = *roll = 0.0;
  for (int i = 0; i < 4; ++i) {
    const double u = -g.motion_ratio * f[i];
    *heave += u;
    *pitch += X(g, i) * u;
    *roll += Y(g, i) * u;
  }
}

struct Motion {
  double z, th, ph;
};

class PureMotionTest : public ::testing::TestWithParam<Motion> {};

TEST_P(PureMotionTest, RatesAndBodyForcesAreTheModalSkyhook) {
  const Motion m = GetParam();
  const BodyGeometry g = Car();
  const ModalGains k{9000.0, 20000.0, 5000.0};
  const ModalSkyhook sky = Configured(g, k);
  double vb[4], f[4];
  Corners(g, m.z, m.th, m.ph, vb);
  const ModalRates q = sky.Rates(vb);
  EXPECT_NEAR(q.heave_m_s, m.z, 1e-12);
  EXPECT_NEAR(q.pitch_rad_s, m.th, 1e-12);
  EXPECT_NEAR(q.roll_rad_s, m.ph, 1e-12);
  sky.Demands(vb, f);
  double heave = 0, pitch = 0, roll = 0;
  OnBody(g, f, &heave, &pitch, &roll);
  EXPECT_NEAR(heave, -k.heave_n_s_per_m * m.z, 1e-9);
  EXPECT_NEAR(pitch, -k.pitch_n_m_s_per_rad * m.th, 1e-9);
  EXPECT_NEAR(roll, -k.roll_n_m_s_per_rad * m.ph, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(ModalSkyhook, PureMotionTest,
                         ::testing::Values(Motion{0.2, 0.0, 0.0}, Motion{0.0, 0.15, 0.0},
                                           Motion{0.0, 0.0, -0.3}, Motion{-0.1, 0.05, 0.2}));

TEST(ModalSkyhookTest, SignsFollowTheDamperConvention) {
  // Body rising (heave up): every damper pulls it down, f > 0. Nose up (pitch > 0): the front
  // dampers pull down (f > 0), the rear push up. Left side up (roll > 0): left f > 0, right < 0.
  const BodyGeometry g = Car();
  const ModalSkyhook sky = Configured(g, ModalGains{});
  double vb[4], f[4];
  Corners(g, 0.1, 0.0, 0.0, vb);
  sky.Demands(vb, f);
  for (int i = 0; i < 4; ++i) EXPECT_GT(f[i], 0.0) << i;
  Corners(g, 0.0, 0.1, 0.0, vb);
  sky.Demands(vb, f);
  EXPECT_GT(f[0], 0.0);
  EXPECT_GT(f[1], 0.0);
  EXPECT_LT(f[2], 0.0);
  EXPECT_LT(f[3], 0.0);
  Corners(g, 0.0, 0.0, 0.1, vb);
  sky.Demands(vb, f);
  EXPECT_GT(f[0], 0.0);
  EXPECT_LT(f[1], 0.0);
  EXPECT_GT(f[2], 0.0);
  EXPECT_LT(f[3], 0.0);
}

TEST(ModalSkyhookTest, UniformGainsOnASymmetricCarEqualPerCornerSkyhookInHeave) {
  // Symmetric both ways (a = b, equal tracks), r 0.7. With a != b the modal skyhook puts the
  // heave force at the centre of gravity (front share b / (a + b), no pitch moment: the pure
  // motion test), where per-corner skyhook also pitches the body.
  BodyGeometry g;
  g.cg_to_front_m = g.cg_to_rear_m = 1.3;
  const double c_sky = 60.0;  // [N s/cm], the per-corner continuous skyhook f = c_sky vb
  ModalGains k;
  k.heave_n_s_per_m = 4.0 * g.motion_ratio * c_sky * 100.0;
  const ModalSkyhook sky = Configured(g, k);
  for (const double vz : {-0.4, 0.03, 0.25}) {
    double vb[4], f[4];
    Corners(g, vz, 0.0, 0.0, vb);
    sky.Demands(vb, f);
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(f[i], c_sky * vb[i], 1e-9) << i;
  }
}

TEST(ModalSkyhookTest, RedundantCornerIsAveragedByLeastSquares) {
  // A warp (FL, RR up; FR, RL down) is no rigid motion: with a = b and equal tracks it is
  // orthogonal to heave, pitch and roll, so it gives no rates and no demand.
  BodyGeometry g;
  g.cg_to_front_m = g.cg_to_rear_m = 1.3;
  const ModalSkyhook sky = Configured(g, ModalGains{});
  const double vb[4] = {5.0, -5.0, -5.0, 5.0};
  const ModalRates q = sky.Rates(vb);
  EXPECT_NEAR(q.heave_m_s, 0.0, 1e-15);
  EXPECT_NEAR(q.pitch_rad_s, 0.0, 1e-15);
  EXPECT_NEAR(q.roll_rad_s, 0.0, 1e-15);
}

TEST(ModalSkyhookTest, RefusesBadGeometryAndGainsWithAReason) {
  const auto refused = [](BodyGeometry g, ModalGains k, const char* field) {
    ModalSkyhook m;
    const char* why = nullptr;
    EXPECT_EQ(m.Configure(g, k, &why), Error::kOutOfRange) << field;
    ASSERT_NE(why, nullptr);
    EXPECT_NE(std::string(why).find(field), std::string::npos) << why;
    EXPECT_FALSE(m.configured());
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  BodyGeometry g;
  g.cg_to_front_m = 0.0;
  refused(g, {}, "cg_to_front_m");
  g = {};
  g.cg_to_rear_m = -1.0;
  refused(g, {}, "cg_to_rear_m");
  g = {};
  g.track_front_m = nan;
  refused(g, {}, "track_front_m");
  g = {};
  g.track_rear_m = 0.0;
  refused(g, {}, "track_rear_m");
  g = {};
  g.motion_ratio = 1.5;
  refused(g, {}, "motion_ratio");
  refused({}, ModalGains{-1.0, 0.0, 0.0}, "heave");
  refused({}, ModalGains{0.0, nan, 0.0}, "pitch");
  refused({}, ModalGains{0.0, 0.0, std::numeric_limits<double>::infinity()}, "roll");
}

TEST(ModalSkyhookTest, UnconfiguredDemandsNothingAndNaNReachesTheDemands) {
  ModalSkyhook idle;
  const double vb[4] = {10.0, 20.0, -5.0, 3.0};
  double f[4] = {1, 1, 1, 1};
  idle.Demands(vb, f);
  for (const double d : f) EXPECT_EQ(d, 0.0);
  const ModalSkyhook sky = Configured({}, {});
  const double bad[4] = {10.0, std::numeric_limits<double>::quiet_NaN(), -5.0, 3.0};
  sky.Demands(bad, f);
  for (const double d : f) EXPECT_FALSE(std::isfinite(d));
}

TEST(ModalSkyhookTest, FourForceTrackingControllersRunWithoutAllocation) {
  const CoefficientTable table = test::DemoDamperTable();
  ControllerConfig config;
  config.law.mode = ControlMode::kForceTracking;
  config.e_max = table.e_max;
  Controller corners[4];
  for (Controller& c : corners) ASSERT_TRUE(c.Configure(table, config).ok());
  const BodyGeometry g;
  const ModalSkyhook sky = Configured(g, ModalGains{});
  constexpr std::int64_t kPeriod = 1'000'000;
  int passive_commands = 0;
  test::AllocationGuard guard;
  for (int k = 1; k <= 2000; ++k) {
    const double t = k * 1e-3;
    double vb[4], f[4];
    Corners(g, 0.2 * std::sin(8 * t), 0.1 * std::sin(9 * t), 0.1 * std::cos(10 * t), vb);
    sky.Demands(vb, f);
    for (int i = 0; i < 4; ++i) {
      SensorFrame frame;
      const double v = 20.0 * std::sin(30 * t + i);  // damper velocity [cm/s]
      frame[Input::kVelocity] = {v, k * kPeriod};
      frame[Input::kDemand] = {f[i], k * kPeriod};
      const ControllerOutput o = corners[i].Update(frame, IoStatus::kOk, false, k * kPeriod, 1e-3);
      EXPECT_FALSE(o.safe);
      passive_commands += o.volts > table.e_min ? 1 : 0;
    }
  }
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_GT(passive_commands, 0);  // the demands reached the inversion
}

}  // namespace
}  // namespace mrd::firmware
