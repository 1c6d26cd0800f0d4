// The three-story structure study: shear-frame plant, clipped rule, observer, LQG design, study.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <string>

#include "mrd/firmware/clipped_optimal.hpp"
#include "mrd/firmware/control_law.hpp"
#include "mrd/sim/shear_frame.hpp"
#include "mrd/structure/design.hpp"
#include "mrd/structure/study.hpp"

namespace mrd::structure {
namespace {

using firmware::ClippedOptimal;
using firmware::ClippedOptimalGains;
using firmware::ClippedRule;
using firmware::Real;

const std::string kRecord = std::string(MRD_SOURCE_DIR) + "/hil/data/el_centro_1940_ns.csv";

// Undamped frequencies from det(K - w^2 M) = 0, found by bisection on the 3x3 determinant
// (independent of the design code's eigen-solver).
double Det(const ShearFrameParams& p, double w2) {
  double a[9];
  for (int i = 0; i < 9; ++i) a[i] = p.stiffness[i];
  for (int i = 0; i < 3; ++i) a[i * 3 + i] -= w2 * p.mass_kg[i];
  return a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
         a[2] * (a[3] * a[7] - a[4] * a[6]);
}

TEST(ShearFrameTest, ModalFrequenciesOfTheDykeFrame) {
  const ShearFrameParams frame;
  const Modes modes = FrameModes(frame);
  // The model's three modes: 5.457, 15.811, 23.638 Hz, lightly damped (< 1 %).
  EXPECT_NEAR(modes.frequency_hz[0], 5.457, 0.005);
  EXPECT_NEAR(modes.frequency_hz[1], 15.811, 0.005);
  EXPECT_NEAR(modes.frequency_hz[2], 23.638, 0.005);
  int found = 0;
  double prev = Det(frame, 1.0);
  for (double w2 = 1.0; w2 < 4e4 * 4.0 * M_PI * M_PI; w2 += 50.0) {
    const double d = Det(frame, w2 + 50.0);
    if ((d > 0) != (prev > 0)) {
      double lo = w2, hi = w2 + 50.0;
      for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        ((Det(frame, mid) > 0) == (Det(frame, lo) > 0) ? lo : hi) = mid;
      }
      ASSERT_LT(found, 3);
      // Damping shifts the damped frequency by far less than 0.1 %.
      EXPECT_NEAR(std::sqrt(lo) / (2 * M_PI), modes.frequency_hz[static_cast<std::size_t>(found)],
                  0.002 * modes.frequency_hz[static_cast<std::size_t>(found)]);
      ++found;
    }
    prev = d;
  }
  EXPECT_EQ(found, 3);
  for (double z : modes.damping_ratio) {
    EXPECT_GT(z, 0.0);
    EXPECT_LT(z, 0.01);
  }
}

// Roof amplitude at the driving frequency f [Hz] over the last second of `seconds` of harmonic
// ground motion (bare frame): a lock-in, so start-up transients of other modes average out.
double RoofAmplitude(double f, double seconds) {
  ShearFrameParams p;
  p.with_damper = false;
  ShearFrame frame(p, SpencerParams::Spencer1997(), 10);
  frame.Reset(0.0, 0.0);
  const double T = 1e-3;
  double si = 0.0, co = 0.0;
  long used = 0;
  const long n = std::lround(seconds / T);
  for (long k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * T;
    const auto& s =
        frame.Step(T, std::sin(2 * M_PI * f * t), std::sin(2 * M_PI * f * (t + T)), 0.0);
    if (t + T > seconds - 1.0) {
      si += s.x[2] * std::sin(2 * M_PI * f * (t + T));
      co += s.x[2] * std::cos(2 * M_PI * f * (t + T));
      ++used;
    }
  }
  return 2.0 / static_cast<double>(used) * std::hypot(si, co);
}

TEST(ShearFrameTest, TheTimeDomainPlantResonatesAtTheModalFrequencies) {
  const Modes modes = FrameModes(ShearFrameParams{});
  for (std::size_t i = 0; i < 2; ++i) {
    const double f = modes.frequency_hz[i];
    const double at = RoofAmplitude(f, 3.0);
    EXPECT_GT(at, 3.0 * RoofAmplitude(0.9 * f, 3.0)) << "mode " << i + 1;
    EXPECT_GT(at, 3.0 * RoofAmplitude(1.1 * f, 3.0)) << "mode " << i + 1;
  }
}

TEST(ShearFrameTest, StaticGroundAccelerationGivesTheStaticDeflection) {
  // ag constant: K x = -M 1 ag at rest; the damper's (dynamic) force vanishes at rest.
  ShearFrameParams p;
  ShearFrame frame(p, SpencerParams::Spencer1997(), 20);
  frame.Reset(0.0, 1.0);
  ShearFrameSample s;
  for (int k = 0; k < 60000; ++k) s = frame.Step(1e-3, 1.0, 1.0, 0.0);
  // Solve K x = -m (1 1 1) with Eigen.
  Eigen::Matrix3d K;
  for (int i = 0; i < 9; ++i) K(i / 3, i % 3) = p.stiffness[i];
  const Eigen::Vector3d x = K.lu().solve(-98.3 * Eigen::Vector3d::Ones());
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(s.x[i], x(i), 0.02 * std::fabs(x(i))) << i;
}

TEST(ShearFrameTest, InvalidParametersAreNamed) {
  ShearFrameParams p;
  const char* reason = nullptr;
  EXPECT_TRUE(p.IsValid(&reason));
  p.mass_kg[1] = 0.0;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "mass_kg");
  p = ShearFrameParams{};
  p.damping[4] = NAN;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "damping");
}

TEST(ClippedRuleTest, SwitchesOnOnlyWhenTheForceMustGrowTowardsTheDesiredForce) {
  const Real vmax = Real(2.25), vmin = Real(0);
  EXPECT_EQ(ClippedRule(Real(500), Real(100), vmax, vmin), vmax);  // same sign, |f| < |fc|
  EXPECT_EQ(ClippedRule(Real(-500), Real(-100), vmax, vmin), vmax);
  EXPECT_EQ(ClippedRule(Real(100), Real(500), vmax, vmin), vmin);  // |f| > |fc|
  EXPECT_EQ(ClippedRule(Real(-100), Real(-500), vmax, vmin), vmin);
  EXPECT_EQ(ClippedRule(Real(-500), Real(100), vmax, vmin), vmin);  // opposite signs
  EXPECT_EQ(ClippedRule(Real(500), Real(-100), vmax, vmin), vmin);
  EXPECT_EQ(ClippedRule(Real(500), Real(0), vmax, vmin), vmin);    // f = 0: H(0) = 0
  EXPECT_EQ(ClippedRule(Real(100), Real(100), vmax, vmin), vmin);  // f = fc
  EXPECT_EQ(ClippedRule(Real(500), Real(100), Real(1.5), Real(0.2)), Real(1.5));
}

TEST(ClippedOptimalTest, TheControlModeIsNamedAndAConfigurableLaw) {
  using firmware::ControlMode;
  EXPECT_STREQ(firmware::ControlModeName(ControlMode::kClippedOptimal), "clipped-optimal");
  firmware::ControlLawConfig c;
  c.mode = ControlMode::kClippedOptimal;
  EXPECT_TRUE(c.IsValid(0.0, 2.25));  // selectable; the Controller needs its gains
  c.clipped_command = static_cast<firmware::ClippedCommand>(7);
  EXPECT_FALSE(c.IsValid(0.0, 2.25));
  c.clipped_command = firmware::ClippedCommand::kInverse;
  firmware::ControlLaw law;
  law.Configure(c, 0.25, 2.25);
  const firmware::ControlOutput out = law.Update({});
  EXPECT_FALSE(out.is_force);
  EXPECT_EQ(out.value, Real(0.25));  // the stateless law holds E_min
}

TEST(ClippedOptimalTest, GainsValidation) {
  ClippedOptimalGains g;
  const char* reason = nullptr;
  EXPECT_TRUE(g.IsValid(&reason));
  g.l[3] = INFINITY;
  EXPECT_FALSE(g.IsValid(&reason));
  EXPECT_STREQ(reason, "l");
  g = ClippedOptimalGains{};
  g.v_min = 3.0;
  EXPECT_FALSE(g.IsValid(&reason));
  EXPECT_STREQ(reason, "v_max");
}

TEST(DesignTest, ClosedLoopAndObserverAreStable) {
  ClippedOptimalGains g;
  std::string error;
  ASSERT_TRUE(DesignClippedOptimal(ShearFrameParams{}, DesignOptions{}, &g, &error)) << error;
  const char* reason = nullptr;
  EXPECT_TRUE(g.IsValid(&reason));
  constexpr int n = ClippedOptimalGains::kStates, m = ClippedOptimalGains::kOutputs;
  Eigen::Matrix<double, n, n> ad, cl, ob;
  Eigen::Matrix<double, n, 1> bd, k;
  Eigen::Matrix<double, m, n> cy;
  Eigen::Matrix<double, n, m> l;
  for (int r = 0; r < n; ++r) {
    bd(r) = g.bd[r];
    k(r) = g.k[r];
    for (int c = 0; c < n; ++c) ad(r, c) = g.ad[r * n + c];
    for (int c = 0; c < m; ++c) l(r, c) = g.l[r * m + c];
  }
  for (int r = 0; r < m; ++r)
    for (int c = 0; c < n; ++c) cy(r, c) = g.cy[r * n + c];
  cl = ad - bd * k.transpose();
  ob = ad - l * cy;
  const double open = ad.eigenvalues().cwiseAbs().maxCoeff();
  EXPECT_LT(cl.eigenvalues().cwiseAbs().maxCoeff(), open);  // LQR adds damping
  EXPECT_LT(ob.eigenvalues().cwiseAbs().maxCoeff(), 1.0);
  // The desired force resists a first-floor displacement (damper force + for x1 > 0).
  EXPECT_GT(-k(0), 0.0);  // f_c = -k . x
}

TEST(DesignTest, BadOptionsAreRefused) {
  ClippedOptimalGains g;
  std::string error;
  DesignOptions o;
  o.period_s = 0.0;
  EXPECT_FALSE(DesignClippedOptimal(ShearFrameParams{}, o, &g, &error));
  EXPECT_NE(error.find("period"), std::string::npos);
  o = DesignOptions{};
  o.q_displacement = 0.0;
  o.q_drift = 0.0;
  EXPECT_FALSE(DesignClippedOptimal(ShearFrameParams{}, o, &g, &error));
}

TEST(ObserverTest, ConvergesOnANoiseFreeRun) {
  // The frame with the passive-off damper shaken by 2 s of El Centro, then at rest on still
  // ground: with measured force and noise-free accelerations the estimate must close in on
  // the true state once the unknown ground motion stops.
  GroundRecord record;
  std::string error;
  ASSERT_TRUE(LoadGroundRecord(kRecord, &record, &error)) << error;
  ClippedOptimalGains g;
  ASSERT_TRUE(DesignClippedOptimal(ShearFrameParams{}, DesignOptions{}, &g, &error)) << error;
  ClippedOptimal law;
  law.Configure(g);
  ShearFrame frame(ShearFrameParams{}, SpencerParams::Spencer1997(), 20);
  frame.Reset(0.0, 0.0);
  const double T = 1e-3, dt = record.dt_s / 5.0;
  const auto ag = [&](double t) {
    if (t >= 2.0) return 0.0;
    const auto i = static_cast<std::size_t>(t / dt);
    const double w = t / dt - static_cast<double>(i);
    return 9.81 * (record.ag_g[i] * (1 - w) + record.ag_g[i + 1] * w);
  };
  ShearFrameSample s = frame.sample();
  double err_shaking = 0.0, err_end = 0.0, peak = 0.0;
  for (int k = 0; k < 4000; ++k) {
    const Real accel[3] = {Real(s.xa[0]), Real(s.xa[1]), Real(s.xa[2])};
    law.Update(accel, Real(s.force));
    const double t = k * T;
    s = frame.Step(T, ag(t), ag(t + T), 0.0);
    double e = 0.0;
    for (int i = 0; i < 3; ++i) e = std::fmax(e, std::fabs(law.estimate()[i] - s.x[i]));
    peak = std::fmax(peak, std::fabs(s.x[2]));
    if (k > 500 && k < 2000) err_shaking = std::fmax(err_shaking, e);
    if (k >= 3900) err_end = std::fmax(err_end, e);
  }
  EXPECT_GT(peak, 1e-3);               // it really moved (> 1 mm)
  EXPECT_LT(err_shaking, 0.5 * peak);  // tracks while shaking
  EXPECT_LT(err_end, 1e-3 * peak);     // converged after the ground stops
  EXPECT_LT(err_end, 0.05 * err_shaking);
}

TEST(GroundRecordTest, TheShippedRecord) {
  GroundRecord r;
  std::string error;
  ASSERT_TRUE(LoadGroundRecord(kRecord, &r, &error)) << error;
  EXPECT_EQ(r.ag_g.size(), 1560U);
  EXPECT_DOUBLE_EQ(r.dt_s, 0.02);
  double peak = 0.0;
  for (double a : r.ag_g) peak = std::fmax(peak, std::fabs(a));
  EXPECT_NEAR(peak, 0.31882, 1e-9);
}

TEST(StudyTest, ProducesEveryCellAndTheClippedOptimalReductions) {
  GroundRecord record;
  std::string error;
  ASSERT_TRUE(LoadGroundRecord(kRecord, &record, &error)) << error;
  const StudyOptions o;
  ClippedOptimalGains g;
  ASSERT_TRUE(DesignClippedOptimal(ShearFrameParams{}, o.design, &g, &error)) << error;
  Response r[4];
  const Case cases[4] = {Case::kUncontrolled, Case::kPassiveOff, Case::kPassiveOn,
                         Case::kClippedOptimal};
  for (int c = 0; c < 4; ++c) {
    ASSERT_TRUE(RunCase(cases[c], record, ShearFrameParams{}, SpencerParams::Spencer1997(), g, o,
                        &r[c], &error))
        << error;
    for (int i = 0; i < 3; ++i) {
      EXPECT_GT(r[c].peak_x_cm[i], 0.0);
      EXPECT_GT(r[c].peak_d_cm[i], 0.0);
      EXPECT_GT(r[c].peak_xa_cm_s2[i], 0.0);
      EXPECT_GT(r[c].rms_x_cm[i], 0.0);
      EXPECT_LT(r[c].rms_x_cm[i], r[c].peak_x_cm[i]);
    }
    EXPECT_EQ(r[c].peak_force_n > 0.0, cases[c] != Case::kUncontrolled);
  }
  const Response &unc = r[0], &off = r[1], &on = r[2], &co = r[3];
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(off.peak_x_cm[i], unc.peak_x_cm[i]);
    EXPECT_LT(co.peak_x_cm[i], off.peak_x_cm[i]);  // better than the passive-off damper
    EXPECT_LT(co.peak_d_cm[i], off.peak_d_cm[i]);
    EXPECT_LT(co.peak_xa_cm_s2[i], unc.peak_xa_cm_s2[i]);
  }
  EXPECT_LE(co.peak_x_cm[2], on.peak_x_cm[2]);  // roof no worse than passive-on
  EXPECT_LT(co.peak_d_cm[1], on.peak_d_cm[1]);  // upper drifts and roof acceleration
  EXPECT_LT(co.peak_d_cm[2], on.peak_d_cm[2]);  // below passive-on's
  EXPECT_LT(co.peak_xa_cm_s2[2], on.peak_xa_cm_s2[2]);
  EXPECT_LT(co.peak_force_n, on.peak_force_n);  // with less force
  EXPECT_GT(co.mean_voltage, 0.0);              // the rule switched
  EXPECT_LT(co.mean_voltage, o.design.v_max);
  // Deterministic: the same run again gives the same numbers.
  Response again;
  ASSERT_TRUE(RunCase(Case::kClippedOptimal, record, ShearFrameParams{},
                      SpencerParams::Spencer1997(), g, o, &again, &error));
  EXPECT_EQ(again.peak_x_cm[2], co.peak_x_cm[2]);
  EXPECT_EQ(again.rms_force_n, co.rms_force_n);
  const std::string table = ResponseTable({unc, off, on, co});
  for (const char* name :
       {"| uncontrolled |", "| passive-off |", "| passive-on |", "| clipped-optimal |"}) {
    EXPECT_NE(table.find(name), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace mrd::structure
