// The shear frame with dampers at several stories: the stroke is the story's drift, the forces
// act on the floors above and below, passive dampers dissipate; the multi-input design (one
// LQR row and one known force input per damper), the firmware law on several forces, the gains
// file with dampers = m, and mrd-structure --dampers.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "mrd/firmware/clipped_optimal.hpp"
#include "mrd/firmware/platform/clipped_optimal_file.hpp"
#include "mrd/sim/shear_frame.hpp"
#include "mrd/structure/design.hpp"
#include "mrd/structure/study.hpp"
#include "support/process.hpp"

namespace mrd::structure {
namespace {

using firmware::ClippedOptimal;
using firmware::ClippedOptimalGains;
using firmware::Real;

const std::string kBin = std::string(MRD_BIN_DIR) + "/mrd-structure";

ShearFrameParams WithDampers(std::initializer_list<int> stories) {
  ShearFrameParams p;
  p.dampers = 0;
  for (int s : stories) p.story[p.dampers++] = s;
  return p;
}

// Harmonic ground acceleration [m/s^2] at the first mode, 0.5 m/s^2.
double Ground(double t) { return 0.5 * std::sin(2.0 * M_PI * 5.46 * t); }

TEST(ShearFrameDampersTest, TheStoriesAreValidatedAndTheDefaultIsOneAtStoryOne) {
  ShearFrameParams p;
  const char* reason = nullptr;
  EXPECT_TRUE(p.IsValid(&reason));
  EXPECT_EQ(p.dampers, 1);
  EXPECT_EQ(p.story[0], 1);
  for (auto stories :
       {std::vector<int>{0}, std::vector<int>{4}, std::vector<int>{2, 2}, std::vector<int>{2, 1}}) {
    ShearFrameParams bad;
    bad.dampers = static_cast<int>(stories.size());
    for (std::size_t j = 0; j < stories.size(); ++j) bad.story[j] = stories[j];
    reason = nullptr;
    EXPECT_FALSE(bad.IsValid(&reason));
    EXPECT_STREQ(reason, "story");
  }
  p.dampers = 4;
  EXPECT_FALSE(p.IsValid(&reason));
  EXPECT_STREQ(reason, "dampers");
  p.dampers = 0;
  EXPECT_FALSE(p.IsValid(&reason));
}

// Each floor's equation of motion holds at every sample with Gamma's columns: -f_j on the
// floor above damper j's story, +f_j on the floor below (none for the ground).
TEST(ShearFrameDampersTest, EveryFloorBalancesWithTheDampersForcesAboveAndBelow) {
  const ShearFrameParams p = WithDampers({1, 2});
  ShearFrame frame(p, SpencerParams::Spencer1997(), 20);
  frame.Reset(0.0, 0.0);
  const double T = 1e-3;
  double worst = 0.0, largest_f2 = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double volts[3] = {0.0, 1.0, 0.0};
    const ShearFrameSample& s = frame.Step(T, Ground(k * T), Ground((k + 1) * T), volts);
    const double gamma_f[3] = {-s.forces[0] + s.forces[1], -s.forces[1], 0.0};
    for (int i = 0; i < 3; ++i) {
      double lhs = p.mass_kg[i] * s.xa[i];  // m (x'' + ag)
      for (int j = 0; j < 3; ++j)
        lhs += p.stiffness[i * 3 + j] * s.x[j] + p.damping[i * 3 + j] * s.v[j];
      worst = std::fmax(worst, std::fabs(lhs - gamma_f[i]));
    }
    largest_f2 = std::fmax(largest_f2, std::fabs(s.forces[1]));
    EXPECT_EQ(s.force, s.forces[0]);
    EXPECT_EQ(s.forces[2], 0.0);
  }
  EXPECT_GT(largest_f2, 20.0);  // the second damper works
  EXPECT_LT(worst, 1e-6);       // [N]: rounding only
}

// A damper at story 2 alone: its force is a Spencer damper's driven by the drift x2 - x1 (a
// standalone SpencerDamper fed the same drift), not by x2 (the floor's displacement).
TEST(ShearFrameDampersTest, ADamperAtStoryTwoStrokesWithTheDriftBetweenFloorsOneAndTwo) {
  const SpencerParams sp = SpencerParams::Spencer1997();
  ShearFrame frame(WithDampers({2}), sp, 20);
  frame.Reset(0.5, 0.0);
  SpencerDamper drift(sp, 100), floor(sp, 100);
  drift.Reset(0.0, 0.5);
  floor.Reset(0.0, 0.5);
  const double f0 = sp.k1 * (0.0 - sp.x0);
  const double T = 1e-3;
  ShearFrameSample prev = frame.sample();
  double err_drift = 0.0, err_floor = 0.0, peak = 0.0;
  for (int k = 0; k < 1500; ++k) {
    const ShearFrameSample s = frame.Step(T, Ground(k * T), Ground((k + 1) * T), 0.5);
    const double fd = drift.Step(T, 100 * (prev.x[1] - prev.x[0]), 100 * (prev.v[1] - prev.v[0]),
                                 100 * (s.x[1] - s.x[0]), 100 * (s.v[1] - s.v[0]), 0.5) -
                      f0;
    const double ff =
        floor.Step(T, 100 * prev.x[1], 100 * prev.v[1], 100 * s.x[1], 100 * s.v[1], 0.5) - f0;
    err_drift = std::fmax(err_drift, std::fabs(s.force - fd));
    err_floor = std::fmax(err_floor, std::fabs(s.force - ff));
    peak = std::fmax(peak, std::fabs(s.force));
    prev = s;
  }
  EXPECT_GT(peak, 20.0);
  EXPECT_LT(err_drift, 0.01 * peak);  // the same force up to the two integrations
  EXPECT_GT(err_floor, 0.2 * peak);   // a stroke of x2 would be a different force
}

// Under the same ground motion each passive damper absorbs energy (its force times its stroke
// rate integrates to > 0), and a second damper at 0 V lowers the roof's response below one.
TEST(ShearFrameDampersTest, PassiveDampersDissipateAndTwoReduceTheResponseBelowOne) {
  const auto run = [](const ShearFrameParams& p, double absorbed[3]) {
    ShearFrame frame(p, SpencerParams::Spencer1997(), 20);
    frame.Reset(0.0, 0.0);
    const double T = 1e-3;
    double sum_x3 = 0.0;
    for (int k = 0; k < 3000; ++k) {
      const ShearFrameSample& s = frame.Step(T, Ground(k * T), Ground((k + 1) * T), 0.0);
      for (int j = 0; j < p.dampers; ++j) {
        const int a = p.story[j] - 1;
        const double rate = s.v[a] - (a > 0 ? s.v[a - 1] : 0.0);  // [m/s]
        absorbed[j] += s.forces[j] * rate * T;                    // [J]
      }
      sum_x3 += s.x[2] * s.x[2];
    }
    return std::sqrt(sum_x3 / 3000.0);
  };
  double one_e[3] = {}, two_e[3] = {};
  const double one = run(WithDampers({1}), one_e);
  const double two = run(WithDampers({1, 2}), two_e);
  EXPECT_GT(one_e[0], 0.0);
  EXPECT_GT(two_e[0], 0.0);
  EXPECT_GT(two_e[1], 0.0);
  EXPECT_LT(two, 0.9 * one);
}

TEST(ShearFrameDampersTest, OneVoltageForAllEqualsTheSameVoltagePerDamper) {
  ShearFrame a(WithDampers({1, 3}), SpencerParams::Spencer1997(), 10);
  ShearFrame b = a;
  const double volts[3] = {1.2, 1.2, 7.0};  // the third is unused
  for (int k = 0; k < 500; ++k) {
    const ShearFrameSample& sa = a.Step(1e-3, Ground(k * 1e-3), Ground((k + 1) * 1e-3), 1.2);
    const ShearFrameSample& sb = b.Step(1e-3, Ground(k * 1e-3), Ground((k + 1) * 1e-3), volts);
    ASSERT_EQ(sa.x[2], sb.x[2]);
    ASSERT_EQ(sa.forces[1], sb.forces[1]);
  }
}

// ---- The multi-input design -----------------------------------------------------------------

struct Matrices {
  Eigen::MatrixXd ad, bd, cy, dy, l, k;
};
Matrices Unpack(const ClippedOptimalGains& g) {
  constexpr int n = ClippedOptimalGains::kStates, o = ClippedOptimalGains::kOutputs;
  const int m = g.dampers;
  Matrices x{Eigen::MatrixXd(n, n), Eigen::MatrixXd(n, m), Eigen::MatrixXd(o, n),
             Eigen::MatrixXd(o, m), Eigen::MatrixXd(n, o), Eigen::MatrixXd(m, n)};
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) x.ad(r, c) = g.ad[r * n + c];
    for (int c = 0; c < m; ++c) x.bd(r, c) = g.bd[r * m + c];
    for (int c = 0; c < o; ++c) x.l(r, c) = g.l[r * o + c];
  }
  for (int r = 0; r < o; ++r) {
    for (int c = 0; c < n; ++c) x.cy(r, c) = g.cy[r * n + c];
    for (int c = 0; c < m; ++c) x.dy(r, c) = g.dy[r * m + c];
  }
  for (int r = 0; r < m; ++r)
    for (int c = 0; c < n; ++c) x.k(r, c) = g.k[r * n + c];
  return x;
}

TEST(MultiInputDesignTest, TwoDampersGiveTwoGainRowsAStableLoopAndTheirOwnInputColumns) {
  ClippedOptimalGains one, two;
  std::string error;
  ASSERT_TRUE(DesignClippedOptimal(WithDampers({1}), DesignOptions{}, &one, &error)) << error;
  ASSERT_TRUE(DesignClippedOptimal(WithDampers({1, 2}), DesignOptions{}, &two, &error)) << error;
  EXPECT_EQ(one.dampers, 1);
  EXPECT_EQ(two.dampers, 2);
  EXPECT_TRUE(two.IsValid(nullptr));
  const Matrices a = Unpack(one), b = Unpack(two);
  // Dy's columns: damper 1 pushes floor 1 back (-1/m1); damper 2 pushes floor 1 forward and
  // floor 2 back.
  const double m1 = 98.3;
  EXPECT_NEAR(b.dy(0, 0), -1.0 / m1, 1e-12);
  EXPECT_NEAR(b.dy(0, 1), 1.0 / m1, 1e-12);
  EXPECT_NEAR(b.dy(1, 1), -1.0 / m1, 1e-12);
  EXPECT_EQ(b.dy(2, 1), 0.0);
  // The first column is the one-damper design's (up to the larger matrix exponential).
  EXPECT_TRUE(b.bd.col(0).isApprox(a.bd.col(0), 1e-9));
  const double open = a.ad.eigenvalues().cwiseAbs().maxCoeff();
  const double cl1 = (a.ad - a.bd * a.k).eigenvalues().cwiseAbs().maxCoeff();
  const double cl2 = (b.ad - b.bd * b.k).eigenvalues().cwiseAbs().maxCoeff();
  EXPECT_LT(cl1, open);
  EXPECT_LT(cl2, cl1);  // a second actuator adds damping to the slowest mode
  EXPECT_LT((b.ad - b.l * b.cy).eigenvalues().cwiseAbs().maxCoeff(), 1.0);
  EXPECT_TRUE(firmware::platform::ClippedObserverStable(two));
  EXPECT_GT(b.k.row(1).norm(), 0.0);

  ShearFrameParams bare = WithDampers({1});
  bare.with_damper = false;
  EXPECT_FALSE(DesignClippedOptimal(bare, DesignOptions{}, &two, &error));
  EXPECT_FALSE(DesignClippedOptimal(WithDampers({2, 2}), DesignOptions{}, &two, &error));
  EXPECT_NE(error.find("distinct stories"), std::string::npos) << error;
}

// ---- The firmware law on several forces ------------------------------------------------------

TEST(MultiInputLawTest, EachDampersVoltageFollowsItsOwnDesiredForceAndForce) {
  ClippedOptimalGains g;
  std::string error;
  ASSERT_TRUE(DesignClippedOptimal(WithDampers({1, 2, 3}), DesignOptions{}, &g, &error)) << error;
  const Matrices x = Unpack(g);
  ClippedOptimal law;
  law.Configure(g);
  ASSERT_EQ(law.dampers(), 3);
  Eigen::VectorXd xh = Eigen::VectorXd::Zero(6);
  int on[3] = {}, off[3] = {};
  for (int k = 0; k < 400; ++k) {
    const Real accel[3] = {Real(std::sin(0.03 * k)), Real(0.5 * std::cos(0.05 * k)),
                           Real(0.2 * std::sin(0.07 * k + 1))};
    const Real force[3] = {Real(50 * std::sin(0.04 * k)), Real(-30 * std::cos(0.02 * k)),
                           Real(10 * std::sin(0.09 * k))};
    Real volts[3] = {-1, -1, -1};
    law.Update(accel, force, volts);
    const Eigen::VectorXd fc = -x.k * xh;
    Eigen::Vector3d y(accel[0], accel[1], accel[2]);
    Eigen::Vector3d f(force[0], force[1], force[2]);
    xh = x.ad * xh + x.bd * f + x.l * (y - x.cy * xh - x.dy * f);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(law.desired_force(j), fc(j), 1e-9 * (1 + std::fabs(fc(j)))) << k << " " << j;
      const bool grow = (fc(j) - f(j)) * f(j) > 0;
      EXPECT_EQ(volts[j], grow ? Real(g.v_max) : Real(g.v_min)) << k << " " << j;
      ++(grow ? on : off)[j];
    }
  }
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(law.estimate()[i], xh(i), 1e-9 * (1 + std::fabs(xh(i))));
  for (int j = 0; j < 3; ++j) {  // each rule switched both ways
    EXPECT_GT(on[j], 0);
    EXPECT_GT(off[j], 0);
  }
}

// ---- The gains file --------------------------------------------------------------------------

TEST(MultiInputGainsFileTest, ATwoDamperFileRoundTripsAndMalformedOnesAreRefused) {
  ClippedOptimalGains g, back;
  std::string error;
  ASSERT_TRUE(DesignClippedOptimal(WithDampers({1, 2}), DesignOptions{}, &g, &error)) << error;
  const std::string text = GainsToml(g, DesignOptions{});
  ASSERT_TRUE(firmware::platform::ParseClippedOptimalGains(text, "g.toml", &back, &error)) << error;
  EXPECT_EQ(back.dampers, 2);
  for (int i = 0; i < 12; ++i) {
    EXPECT_EQ(back.k[i], g.k[i]) << i;
    EXPECT_EQ(back.bd[i], g.bd[i]) << i;
  }
  for (int i = 0; i < 6; ++i) EXPECT_EQ(back.dy[i], g.dy[i]) << i;
  const auto replace = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    t.replace(t.find(from), from.size(), to);
    return t;
  };
  struct Case {
    std::string text;
    const char* reason;
  };
  const Case cases[] = {
      {replace("dampers = 2", "dampers = 0"), "g.toml:3: 'dampers' must be an integer in [1, 3]"},
      {replace("dampers = 2", "dampers = 4"), "g.toml:3: 'dampers' must be an integer in [1, 3]"},
      {replace("dampers = 2", "dampers = 1.5"), "'dampers' must be an integer"},
      {replace("dampers = 2", "dampers = \"2\""), "'dampers' must be an integer"},
      {replace("dampers = 2", "dampers = 3"),
       "'bd' must be a list of 18 numbers (has 12) for "
       "dampers = 3"},
      {replace("dampers = 2\n", ""), "'bd' must be a list of 6 numbers (has 12)"}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.text.substr(0, 160));
    EXPECT_FALSE(firmware::platform::ParseClippedOptimalGains(c.text, "g.toml", &back, &error));
    EXPECT_NE(error.find(c.reason), std::string::npos) << error;
  }
}

// ---- mrd-structure --dampers -----------------------------------------------------------------

TEST(StructureDampersCliTest, TheStudyAndDesignTakeTheStoriesAndRefuseBadOnes) {
  mrd::test::ChildProcess study({kBin, "study", "--dampers", "2,1"});
  ASSERT_EQ(study.Wait(120), 0) << study.Stderr();
  const std::string out = study.Stdout();
  EXPECT_NE(out.find("| clipped-optimal | 2 (2) |"), std::string::npos) << out;
  EXPECT_NE(out.find("| passive-on | 1 (1) |"), std::string::npos) << out;
  mrd::test::ChildProcess one({kBin, "study"});
  ASSERT_EQ(one.Wait(120), 0) << one.Stderr();
  EXPECT_EQ(one.Stdout().find("Per damper"), std::string::npos);
  EXPECT_NE(out.substr(0, out.find("Per damper")), one.Stdout());

  mrd::test::ChildProcess design({kBin, "design", "--dampers", "1,3"});
  ASSERT_EQ(design.Wait(60), 0) << design.Stderr();
  ClippedOptimalGains g;
  std::string error;
  ASSERT_TRUE(firmware::platform::ParseClippedOptimalGains(design.Stdout(), "d", &g, &error))
      << error;
  EXPECT_EQ(g.dampers, 2);

  for (const char* bad : {"", "0", "4", "1,1", "1,,2", "1;2", "one", "1,2,3,1"}) {
    for (const char* cmd : {"study", "design"}) {
      mrd::test::ChildProcess p({kBin, cmd, "--dampers", bad});
      EXPECT_EQ(p.Wait(60), 2) << cmd << " " << bad;
      EXPECT_EQ(p.Stderr().rfind(std::string("error: --dampers: '") + bad + "':", 0), 0U)
          << p.Stderr();
      EXPECT_EQ(p.Stdout(), "");
    }
  }
}

}  // namespace
}  // namespace mrd::structure
