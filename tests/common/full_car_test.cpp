// Full car (common/sim/include/mrd/sim/full_car.hpp) and its two-track road
// (two_track_road.hpp): equilibrium on an uneven road, left/right symmetry, the rear wheels'
// delay, the tracks' correlation, energy (conserved without dampers, decaying with them), the
// natural frequencies against an eigen analysis of the mass and stiffness matrices built here
// from the parameters, a symmetric car against four quarter cars, no allocation.
// The allocation counter (tests/support/alloc_counter.hpp) replaces the allocator of this
// executable.
#include "mrd/sim/full_car.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "mrd/sim/quarter_car.hpp"
#include "mrd/sim/two_track_road.hpp"
#include "support/alloc_counter.hpp"

namespace mrd {
namespace {

constexpr double kPeriod = 1e-3;  // [s]
constexpr double kTwoPi = 2.0 * std::numbers::pi;
const CornerValues kZero{};

double Spring(const FullCarParams& p, int i) {
  return i < 2 ? p.spring_front_n_per_m : p.spring_rear_n_per_m;
}
double Unsprung(const FullCarParams& p, int i) {
  return i < 2 ? p.unsprung_front_kg : p.unsprung_rear_kg;
}

// Mechanical energy [J] of the car on a flat road (springs, tyres, masses).
double Energy(const FullCar& car) {
  const FullCarParams& p = car.params();
  const FullCar::State& s = car.state();
  double e = 0.5 * p.body_mass_kg * s.vz * s.vz + 0.5 * p.pitch_inertia_kg_m2 * s.wth * s.wth +
             0.5 * p.roll_inertia_kg_m2 * s.wph * s.wph;
  for (int i = 0; i < 4; ++i) {
    const double d = car.Sample().corner[i].travel_m;
    e += 0.5 * Unsprung(p, i) * s.vu[i] * s.vu[i] + 0.5 * Spring(p, i) * d * d +
         0.5 * p.tyre_n_per_m * s.zu[i] * s.zu[i];
  }
  return e;
}

// Passive damper at every corner: f = c xdot at the damper [N], c in N s/cm.
CornerValues Dashpot(const FullCarSample& s, double c) {
  CornerValues f;
  for (int i = 0; i < 4; ++i) f[i] = c * s.corner[i].damper_v_cm_s;
  return f;
}

TEST(FullCarTest, ParamsAreCheckedByName) {
  const char* reason = nullptr;
  EXPECT_TRUE(FullCarParams{}.IsValid(&reason));
  FullCarParams p;
  p.roll_inertia_kg_m2 = 0.0;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "roll_inertia_kg_m2");
  p = FullCarParams{};
  p.motion_ratio = 1.5;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "motion_ratio");
  p = FullCarParams{};
  p.tyre_damping_n_s_per_m = std::nan("");
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "tyre_damping_n_s_per_m");
  TwoTrackRoadParams r;
  EXPECT_TRUE(r.IsValid(&reason));
  r.correlation = 1.01;
  EXPECT_FALSE(r.IsValid(&reason));
  EXPECT_STREQ(reason, "correlation");
  r = TwoTrackRoadParams{};
  r.wheelbase_m = 0.0;
  EXPECT_FALSE(r.IsValid(&reason));
  EXPECT_STREQ(reason, "wheelbase_m");
  r = TwoTrackRoadParams{};
  r.road.n_max = 0.0;
  EXPECT_FALSE(r.IsValid(&reason));
  EXPECT_STREQ(reason, "n_max");
}

// No road, no damper force: nothing moves. On an uneven road (four different heights, held)
// Reset solves the static equilibrium: the car stays put too, tilted.
TEST(FullCarTest, RestsInStaticEquilibriumOnFlatAndUnevenRoads) {
  FullCar car{FullCarParams{}};
  for (int k = 0; k < 2000; ++k) car.Step(kPeriod, kZero, kZero, kZero);
  EXPECT_EQ(car.state().z, 0.0);
  EXPECT_EQ(car.state().th, 0.0);
  EXPECT_EQ(car.state().ph, 0.0);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(car.state().zu[i], 0.0);

  const CornerValues road{0.03, -0.01, 0.02, 0.045};
  car.Reset(road, kZero);
  const FullCar::State s0 = car.state();
  EXPECT_NE(s0.th, 0.0);
  EXPECT_NE(s0.ph, 0.0);
  for (int k = 0; k < 2000; ++k) car.Step(kPeriod, road, kZero, kZero);
  EXPECT_NEAR(car.state().z, s0.z, 1e-12);
  EXPECT_NEAR(car.state().th, s0.th, 1e-12);
  EXPECT_NEAR(car.state().ph, s0.ph, 1e-12);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(car.state().zu[i], s0.zu[i], 1e-12);
  EXPECT_NEAR(car.Sample().heave_accel, 0.0, 1e-9);
  EXPECT_NEAR(car.Sample().pitch_accel, 0.0, 1e-9);
  EXPECT_NEAR(car.Sample().roll_accel, 0.0, 1e-9);
}

// A positive (extension-resisting) damper force at the front left pulls that corner's body down
// and its wheel up: heave, pitch (nose) and roll (left) accelerate negative, at -r f / M,
// -r f a / I_pitch, -r f (t/2) / I_roll at the first instant.
TEST(FullCarTest, DamperForceSignsAndOutputsAreConsistent) {
  const FullCarParams p;
  FullCar car{p};
  const double f = 500.0, r = p.motion_ratio;
  const FullCarSample& s = car.Step(1e-6, kZero, kZero, CornerValues{f, 0.0, 0.0, 0.0});
  EXPECT_NEAR(s.heave_accel, -r * f / p.body_mass_kg, 1e-3 * r * f / p.body_mass_kg);
  EXPECT_NEAR(s.pitch_accel, -r * f * p.cg_to_front_m / p.pitch_inertia_kg_m2, 1e-3);
  EXPECT_NEAR(s.roll_accel, -r * f * 0.5 * p.track_front_m / p.roll_inertia_kg_m2, 1e-3);
  EXPECT_GT(car.state().vu[kFrontLeft], 0.0);
  EXPECT_EQ(s.corner[kFrontLeft].damper_force_n, f);
  // Outputs on a moving car.
  for (int k = 0; k < 300; ++k) {
    const double t = k * kPeriod;
    const CornerValues road{0.01 * std::sin(9.0 * t), 0.0, 0.0, 0.02 * std::sin(5.0 * t)};
    const CornerValues rate{0.09 * std::cos(9.0 * t), 0.0, 0.0, 0.1 * std::cos(5.0 * t)};
    car.Step(kPeriod, road, rate, Dashpot(car.Sample(), 10.0));
  }
  const FullCar::State& x = car.state();
  for (int i = 0; i < 4; ++i) {
    const FullCarCorner& c = car.Sample().corner[i];
    const double xi = p.corner_x_m(i), yi = p.corner_y_m(i);
    EXPECT_NEAR(c.travel_m, x.z + xi * x.th + yi * x.ph - x.zu[i], 1e-15);
    EXPECT_NEAR(c.body_velocity_m_s, x.vz + xi * x.wth + yi * x.wph, 1e-15);
    EXPECT_EQ(c.wheel_velocity_m_s, x.vu[i]);
    EXPECT_NEAR(c.travel_rate_m_s, c.body_velocity_m_s - c.wheel_velocity_m_s, 1e-15);
    EXPECT_NEAR(c.damper_x_cm, 100.0 * r * c.travel_m, 1e-12);
    EXPECT_NEAR(c.damper_v_cm_s, 100.0 * r * c.travel_rate_m_s, 1e-12);
    EXPECT_NEAR(c.tyre_load_n, p.tyre_n_per_m * c.tyre_deflection_m, 1e-9);
  }
  const FullCarSample& o = car.Sample();
  EXPECT_NEAR(o.seat_accel, o.heave_accel + p.seat_x_m * o.pitch_accel + p.seat_y_m * o.roll_accel,
              1e-12);
  EXPECT_NEAR(car.PointAccel(0.0, 0.0), o.heave_accel, 1e-15);
  EXPECT_NEAR(o.t_s, 0.3 + 1e-6, 1e-12);
}

// Identical tracks (correlation 1): heave and pitch respond (the rear a wheelbase later),
// roll stays at zero to round-off. Correlation 0 rolls the body.
TEST(FullCarTest, SymmetricRoadExcitesHeaveAndPitchButNoRoll) {
  const double speed = 20.0;
  for (const double rho : {1.0, 0.0}) {
    TwoTrackRoadParams rp;
    rp.correlation = rho;
    TwoTrackRoad road(rp, speed * kPeriod);
    FullCar car{FullCarParams{}};
    CornerValues rate;
    const auto rates = [&] {
      for (int i = 0; i < 4; ++i) rate[i] = speed * road.slopes()[i];
      return rate;
    };
    car.Reset(road.heights_m(), rates());
    double roll_peak = 0.0, pitch2 = 0.0, heave2 = 0.0, roll2 = 0.0;
    const int n = 10000;
    for (int k = 0; k < n; ++k) {
      road.Advance();
      const FullCarSample& s =
          car.Step(kPeriod, road.heights_m(), rates(), Dashpot(car.Sample(), 19.0));
      roll_peak = std::max(roll_peak, std::fabs(s.roll_rate));
      roll2 += s.roll_rate * s.roll_rate;
      pitch2 += s.pitch_rate * s.pitch_rate;
      heave2 += s.heave_accel * s.heave_accel;
    }
    const double pitch_rms = std::sqrt(pitch2 / n), heave_rms = std::sqrt(heave2 / n);
    const double roll_rms = std::sqrt(roll2 / n);
    std::printf(
        "rho %.0f: heave acc RMS %.3f m/s^2, pitch rate RMS %.4f rad/s, roll rate RMS %.4g\n", rho,
        heave_rms, pitch_rms, roll_rms);
    EXPECT_GT(heave_rms, 0.3);
    EXPECT_GT(pitch_rms, 0.01);
    if (rho == 1.0) {
      EXPECT_LT(roll_peak, 1e-12);
    } else {
      EXPECT_GT(roll_rms, 0.5 * pitch_rms);
    }
  }
}

// Left wheels up, right wheels down by the same bump: roll only; heave and pitch stay zero.
TEST(FullCarTest, AntiSymmetricRoadExcitesRollOnly) {
  FullCar car{FullCarParams{}};
  double roll_peak = 0.0, heave_peak = 0.0, pitch_peak = 0.0;
  for (int k = 0; k < 3000; ++k) {
    const double t = (k + 1) * kPeriod;
    const double w = kTwoPi * 2.0;  // a 2 Hz half-sine bump of 2 cm over the first 0.25 s
    const double h = t < 0.25 ? 0.02 * std::sin(w * t) : 0.0;
    const double v = t < 0.25 ? 0.02 * w * std::cos(w * t) : 0.0;
    const FullCarSample& s = car.Step(kPeriod, CornerValues{h, -h, h, -h},
                                      CornerValues{v, -v, v, -v}, Dashpot(car.Sample(), 19.0));
    roll_peak = std::max(roll_peak, std::fabs(s.roll_rate));
    heave_peak = std::max(heave_peak, std::fabs(s.heave_velocity_m_s));
    pitch_peak = std::max(pitch_peak, std::fabs(s.pitch_rate));
  }
  EXPECT_GT(roll_peak, 0.05);
  EXPECT_LT(heave_peak, 1e-15);
  EXPECT_LT(pitch_peak, 1e-15);
}

// The rear wheels' road is the front wheels' a wheelbase later: with wheelbase / (speed dt)
// whole (2.6 m at 20 m/s, 1 ms: 130 steps) sample by sample; at any speed (17 m/s) against the
// track evaluated at s - wheelbase.
TEST(TwoTrackRoadTest, RearWheelsSeeTheFrontRoadAWheelbaseLater) {
  TwoTrackRoadParams rp;
  rp.wheelbase_m = 2.6;
  TwoTrackRoad road(rp, 20.0 * kPeriod);
  std::vector<CornerValues> front;
  for (int k = 0; k < 5000; ++k) {
    front.push_back(road.heights_m());
    if (k >= 130) {
      EXPECT_NEAR(road.heights_m()[kRearLeft], front[k - 130][kFrontLeft], 1e-12) << k;
      EXPECT_NEAR(road.heights_m()[kRearRight], front[k - 130][kFrontRight], 1e-12) << k;
    }
    road.Advance();
  }
  TwoTrackRoad odd(rp, 17.0 * kPeriod);
  for (int k = 0; k < 3000; ++k) odd.Advance();
  const double s = odd.distance_m();
  EXPECT_NEAR(s, 51.0, 1e-9);
  EXPECT_NEAR(odd.heights_m()[kFrontLeft], odd.TrackHeight(true, s), 1e-12);
  EXPECT_NEAR(odd.heights_m()[kRearLeft], odd.TrackHeight(true, s - 2.6), 1e-12);
  EXPECT_NEAR(odd.heights_m()[kRearRight], odd.TrackHeight(false, s - 2.6), 1e-12);
  EXPECT_NE(odd.heights_m()[kRearLeft], odd.heights_m()[kRearRight]);
}

// Each track keeps the class's variance; the left/right correlation over 20 km is the stated
// one; the same seed gives the same road, another seed another.
TEST(TwoTrackRoadTest, TracksKeepTheClassAndTheStatedCorrelation) {
  for (const double rho : {0.0, 0.5, 0.9}) {
    TwoTrackRoadParams rp;
    rp.correlation = rho;
    TwoTrackRoad road(rp, 0.1);
    double ll = 0.0, rr = 0.0, lr = 0.0;
    const int n = 200000;  // 20 km
    for (int k = 0; k < n; ++k) {
      const double l = road.heights_m()[kFrontLeft], r = road.heights_m()[kFrontRight];
      ll += l * l;
      rr += r * r;
      lr += l * r;
      road.Advance();
    }
    const double band = Iso8608BandVariance(RoadClass::kC, rp.road.n_min, rp.road.n_max);
    const double corr = lr / std::sqrt(ll * rr);
    std::printf("rho %.1f: left var %.4f, right var %.4f of the band, correlation %.3f\n", rho,
                ll / n / band, rr / n / band, corr);
    EXPECT_NEAR(ll / n / band, 1.0, 0.05);
    EXPECT_NEAR(rr / n / band, 1.0, 0.05);
    EXPECT_NEAR(corr, rho, 0.03);
  }
  TwoTrackRoadParams rp;
  TwoTrackRoad a(rp, 0.02), b(rp, 0.02);
  rp.road.seed = 2;
  TwoTrackRoad c(rp, 0.02);
  for (int k = 0; k < 1000; ++k) {
    a.Advance();
    b.Advance();
    c.Advance();
  }
  EXPECT_EQ(a.heights_m(), b.heights_m());
  EXPECT_NE(a.heights_m()[kFrontLeft], c.heights_m()[kFrontLeft]);
}

// Released from an arbitrary displaced state on a flat road: without dampers the energy stays
// (RK4 at 1 ms: drift below 1e-6 over 5 s); with passive dampers f = c xdot at every corner it
// decays below 1 % in 5 s and never rises over a 50 ms window.
TEST(FullCarTest, EnergyIsConservedWithoutDampersAndDecaysWithThem) {
  FullCarParams p;
  p.spring_rear_n_per_m = 24000.0;  // an asymmetric car: every coupling at work
  p.unsprung_rear_kg = 45.0;
  p.track_rear_m = 1.46;
  FullCar::State s0{};
  s0.z = 0.02;
  s0.th = 0.01;
  s0.ph = -0.012;
  s0.vz = 0.1;
  s0.zu = CornerValues{0.004, -0.002, 0.0, 0.003};
  for (const double c : {0.0, 19.0}) {
    FullCar car{p};
    car.SetState(s0, kZero, kZero);
    const double e0 = Energy(car);
    double window_max = e0, last_window_max = 2.0 * e0;
    for (int k = 1; k <= 5000; ++k) {
      car.Step(kPeriod, kZero, kZero, Dashpot(car.Sample(), c));
      window_max = std::max(window_max, Energy(car));
      if (k % 50 == 0) {
        if (c > 0.0) {
          EXPECT_LE(window_max, last_window_max) << k;
        }
        last_window_max = window_max;
        window_max = 0.0;
      }
    }
    const double e1 = Energy(car);
    std::printf("c %.0f N s/cm: energy %.4g J -> %.4g J after 5 s\n", c, e0, e1);
    if (c == 0.0) {
      EXPECT_NEAR(e1 / e0, 1.0, 1e-6);
    } else {
      EXPECT_LT(e1, 0.01 * e0);
    }
  }
}

// Cyclic Jacobi: eigenvalues w and eigenvectors (columns of v) of the symmetric 7x7 a.
void Jacobi(double a[7][7], double v[7][7], double w[7]) {
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j) v[i][j] = i == j ? 1.0 : 0.0;
  for (int sweep = 0; sweep < 100; ++sweep) {
    double off = 0.0;
    for (int i = 0; i < 7; ++i)
      for (int j = i + 1; j < 7; ++j) off += a[i][j] * a[i][j];
    if (off < 1e-30) break;
    for (int p = 0; p < 7; ++p) {
      for (int q = p + 1; q < 7; ++q) {
        if (a[p][q] == 0.0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t =
            (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1.0 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < 7; ++k) {  // columns p, q
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 7; ++k) {  // rows p, q
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 7; ++k) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
    }
  }
  for (int i = 0; i < 7; ++i) w[i] = a[i][i];
}

struct Mode {
  double hz;
  double shape[7];  // (z, th, ph, zu FL, FR, RL, RR) [m, rad]
};

// Undamped modes from M and K built from the parameters (coordinates z, th, ph, zu_i):
// V = sum_i ks_i (z + x_i th + y_i ph - zu_i)^2 / 2 + kt zu_i^2 / 2.
std::vector<Mode> Modes(const FullCarParams& p) {
  double k[7][7] = {}, m[7] = {p.body_mass_kg, p.pitch_inertia_kg_m2, p.roll_inertia_kg_m2};
  for (int i = 0; i < 4; ++i) {
    const double g[3] = {1.0, p.corner_x_m(i), p.corner_y_m(i)};
    const double ks = Spring(p, i);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) k[r][c] += ks * g[r] * g[c];
      k[r][3 + i] -= ks * g[r];
      k[3 + i][r] -= ks * g[r];
    }
    k[3 + i][3 + i] = ks + p.tyre_n_per_m;
    m[3 + i] = Unsprung(p, i);
  }
  double a[7][7], v[7][7], w[7];
  for (int r = 0; r < 7; ++r)
    for (int c = 0; c < 7; ++c) a[r][c] = k[r][c] / std::sqrt(m[r] * m[c]);
  Jacobi(a, v, w);
  std::vector<Mode> modes(7);
  for (int j = 0; j < 7; ++j) {
    modes[j].hz = std::sqrt(w[j]) / kTwoPi;
    for (int r = 0; r < 7; ++r) modes[j].shape[r] = v[r][j] / std::sqrt(m[r]);
  }
  std::sort(modes.begin(), modes.end(), [](const Mode& x, const Mode& y) { return x.hz < y.hz; });
  return modes;
}

// The model's free response from a mode shape (no damping, flat road): frequency from the zero
// crossings of the mode's largest coordinate over ~20 cycles.
double FreeResponseHz(const FullCarParams& p, const Mode& mode) {
  int big = 0;
  for (int r = 1; r < 7; ++r)
    if (std::fabs(mode.shape[r]) > std::fabs(mode.shape[big])) big = r;
  const double scale = 0.005 / std::fabs(mode.shape[big]);  // 5 mm (or 5 mrad)
  FullCar::State s{};
  s.z = scale * mode.shape[0];
  s.th = scale * mode.shape[1];
  s.ph = scale * mode.shape[2];
  for (int i = 0; i < 4; ++i) s.zu[i] = scale * mode.shape[3 + i];
  FullCar car{p};
  car.SetState(s, kZero, kZero);
  const double dt = 0.01 / mode.hz;  // 100 steps per period
  const auto coord = [&] {
    const FullCar::State& x = car.state();
    const double q[7] = {x.z, x.th, x.ph, x.zu[0], x.zu[1], x.zu[2], x.zu[3]};
    return q[big];
  };
  double prev = coord(), first = -1.0, last = -1.0;
  int crossings = 0;
  for (int k = 1; k <= 2000; ++k) {
    car.Step(dt, kZero, kZero, kZero);
    const double now = coord();
    if ((prev < 0.0) != (now < 0.0)) {
      const double t = (k - 1 + prev / (prev - now)) * dt;
      if (first < 0.0) first = t;
      last = t;
      ++crossings;
    }
    prev = now;
  }
  return 0.5 * (crossings - 1) / (last - first);
}

// Natural frequencies: the model's free response agrees with the eigen analysis within 0.2 %;
// the eigen frequencies with the textbook formulas within 3 %: heave sqrt(sum k_i / M), pitch
// sqrt(sum k_i x_i^2 / I_pitch), roll sqrt(sum k_i y_i^2 / I_roll) (k_i = ks kt / (ks + kt),
// the corner's ride rate; exact when heave and pitch decouple, sum k_i x_i = 0, and the wheels
// are rigid) and wheel hop sqrt((ks + kt) / mu) (the body held still).
TEST(FullCarTest, NaturalFrequenciesMatchTheAnalyticValues) {
  const FullCarParams p;
  const std::vector<Mode> modes = Modes(p);
  const auto ride = [&](int i) {
    const double ks = Spring(p, i);
    return ks * p.tyre_n_per_m / (ks + p.tyre_n_per_m);
  };
  double kz = 0.0, kth = 0.0, kph = 0.0;
  for (int i = 0; i < 4; ++i) {
    kz += ride(i);
    kth += ride(i) * p.corner_x_m(i) * p.corner_x_m(i);
    kph += ride(i) * p.corner_y_m(i) * p.corner_y_m(i);
  }
  const double heave = std::sqrt(kz / p.body_mass_kg) / kTwoPi;
  const double pitch = std::sqrt(kth / p.pitch_inertia_kg_m2) / kTwoPi;
  const double roll = std::sqrt(kph / p.roll_inertia_kg_m2) / kTwoPi;
  const double hop =
      std::sqrt((p.spring_front_n_per_m + p.tyre_n_per_m) / p.unsprung_front_kg) / kTwoPi;
  // Label the three body modes by their dominant body coordinate (energy share).
  double found[3] = {0.0, 0.0, 0.0};
  const double inertia[3] = {p.body_mass_kg, p.pitch_inertia_kg_m2, p.roll_inertia_kg_m2};
  for (int j = 0; j < 3; ++j) {
    int dom = 0;
    for (int r = 1; r < 3; ++r) {
      if (inertia[r] * modes[j].shape[r] * modes[j].shape[r] >
          inertia[dom] * modes[j].shape[dom] * modes[j].shape[dom])
        dom = r;
    }
    found[dom] = modes[j].hz;
  }
  std::printf("eigen: heave %.3f pitch %.3f roll %.3f Hz (formulas %.3f %.3f %.3f); wheel hop",
              found[0], found[1], found[2], heave, pitch, roll);
  for (int j = 3; j < 7; ++j) std::printf(" %.3f", modes[j].hz);
  std::printf(" Hz (formula %.3f)\n", hop);
  EXPECT_NEAR(found[0] / heave, 1.0, 0.03);
  EXPECT_NEAR(found[1] / pitch, 1.0, 0.03);
  EXPECT_NEAR(found[2] / roll, 1.0, 0.03);
  EXPECT_GT(found[0], 1.0);
  EXPECT_LT(found[0], 1.5);
  for (int j = 3; j < 7; ++j) {
    EXPECT_NEAR(modes[j].hz / hop, 1.0, 0.03) << j;
    EXPECT_GT(modes[j].hz, 10.0);
    EXPECT_LT(modes[j].hz, 12.0);
  }
  for (const Mode& mode : modes) {
    const double measured = FreeResponseHz(p, mode);
    EXPECT_NEAR(measured / mode.hz, 1.0, 0.002) << mode.hz;
  }
}

// A symmetric car (a = b, equal springs) with the same road under all four wheels never pitches
// or rolls (by symmetry, exactly), so each corner is a quarter car of a quarter of the body: with
// the quarter car's damper reduced to a linear dashpot (Spencer with alpha, k0, k1, the
// hysteresis and the voltage terms zero: f = c0 c1 / (c0 + c1) xdot), the same dashpot inside
// the full car at the wheel (100 r^2 c0 c1 / (c0 + c1) N s/m) and the same ISO 8608 road, the
// two models agree to round-off on class C at 20 m/s.
TEST(FullCarTest, SymmetricCarOnOneTrackIsFourQuarterCars) {
  SpencerParams dashpot = SpencerParams::Paper();
  dashpot.alpha_a = dashpot.alpha_b = dashpot.A = dashpot.gamma = dashpot.beta = 0.0;
  dashpot.k0 = dashpot.k1 = dashpot.x0 = dashpot.c0b = dashpot.c1b = 0.0;
  const double ceq = dashpot.c0a * dashpot.c1a / (dashpot.c0a + dashpot.c1a);  // [N s/cm]
  const QuarterCarParams qp;
  QuarterCarPlant quarter(dashpot, qp, RoadParams{}, kPeriod);

  FullCarParams p;
  p.body_mass_kg = 4.0 * qp.sprung_mass_kg;
  p.cg_to_front_m = p.cg_to_rear_m = 1.3;
  p.unsprung_front_kg = p.unsprung_rear_kg = qp.unsprung_mass_kg;
  p.spring_front_n_per_m = p.spring_rear_n_per_m = qp.spring_n_per_m;
  p.tyre_n_per_m = qp.tyre_n_per_m;
  p.motion_ratio = qp.motion_ratio;
  p.damping_front_n_s_per_m = p.damping_rear_n_s_per_m =
      100.0 * qp.motion_ratio * qp.motion_ratio * ceq;
  p.substeps = qp.substeps;
  FullCar car{p};
  const Iso8608Road iso{RoadParams{}};
  RoadTrack track(iso, qp.speed_m_s * kPeriod);
  const auto all = [](double v) { return CornerValues{v, v, v, v}; };
  car.Reset(all(track.height_m()), all(qp.speed_m_s * track.slope()));
  double err_body = 0.0, err_wheel = 0.0, travel_peak = 0.0;
  for (int k = 0; k < 10000; ++k) {
    track.Advance();
    quarter.Step(0.0);
    const FullCarSample& s =
        car.Step(kPeriod, all(track.height_m()), all(qp.speed_m_s * track.slope()), kZero);
    // No pitch or roll but round-off: the rates sum equal and opposite corner moments, exactly
    // zero on x86-64, within 1e-17 rad/s where the compiler fuses a*b+c (aarch64).
    EXPECT_LE(std::fabs(s.pitch_rate), 1e-12);
    EXPECT_LE(std::fabs(s.roll_rate), 1e-12);
    err_body = std::max(err_body, std::fabs(car.state().z - quarter.state().zs));
    err_wheel = std::max(err_wheel, std::fabs(car.state().zu[kRearRight] - quarter.state().zu));
    travel_peak = std::max(travel_peak, std::fabs(s.corner[kFrontLeft].travel_m));
  }
  std::printf("full car vs quarter car over 10 s: body %.3g m, wheel %.3g m (travel peak %.3g m)\n",
              err_body, err_wheel, travel_peak);
  EXPECT_GT(travel_peak, 0.005);
  EXPECT_LT(err_body, 1e-12);
  EXPECT_LT(err_wheel, 1e-12);
}

TEST(FullCarTest, RunsAreDeterministic) {
  const auto run = [] {
    TwoTrackRoad road(TwoTrackRoadParams{}, 20.0 * kPeriod);
    FullCar car{FullCarParams{}};
    CornerValues rate;
    for (int k = 0; k < 3000; ++k) {
      road.Advance();
      for (int i = 0; i < 4; ++i) rate[i] = 20.0 * road.slopes()[i];
      car.Step(kPeriod, road.heights_m(), rate, Dashpot(car.Sample(), 19.0));
    }
    return car.Sample();
  };
  const FullCarSample a = run(), b = run();
  EXPECT_EQ(a.seat_accel, b.seat_accel);
  EXPECT_EQ(a.roll_rate, b.roll_rate);
  EXPECT_EQ(a.corner[kRearRight].tyre_load_n, b.corner[kRearRight].tyre_load_n);
}

TEST(FullCarTest, StepAndRoadAllocateNothing) {
  TwoTrackRoad road(TwoTrackRoadParams{}, 20.0 * kPeriod);
  FullCar car{FullCarParams{}};
  {
    test::ThreadAllocationGuard guard;
    ::operator delete(::operator new(8));  // the counter counts (a call, not elidable)
    guard.Stop();
    ASSERT_GE(guard.CountOn(gettid()), 1U);
  }
  test::ThreadAllocationGuard guard;
  CornerValues rate;
  for (int k = 0; k < 2000; ++k) {
    road.Advance();
    for (int i = 0; i < 4; ++i) rate[i] = 20.0 * road.slopes()[i];
    car.Step(kPeriod, road.heights_m(), rate, Dashpot(car.Sample(), 19.0));
  }
  road.Reset();
  car.Reset(road.heights_m(), kZero);
  guard.Stop();
  EXPECT_EQ(guard.CountOn(gettid()), 0U) << "the car or the road allocated:\n" << guard.Report();
}

}  // namespace
}  // namespace mrd
