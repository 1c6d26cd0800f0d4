// The clipped-optimal law in the firmware: the gains file (mrd-structure design --out) and its
// refusals, the [clipped_optimal] section and the routing of its inputs, and the law through
// the Controller (clipped rule by hand, the inverse command against the force law, the
// watchdog on its inputs, Retune).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/platform/clipped_optimal_file.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "support/demo_model.hpp"
#include "support/process.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kMs = 1'000'000;
const std::string kGainsFile = std::string(MRD_SOURCE_DIR) + "/hil/data/clipped_optimal_gains.toml";

std::string Read(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A fresh directory with files in it.
struct TempDir {
  TempDir() {
    char t[] = "/tmp/mrd-clipped-XXXXXX";
    path = mkdtemp(t) != nullptr ? t : "/tmp";
  }
  std::string Write(const std::string& name, const std::string& text) const {
    std::ofstream(path + "/" + name) << text;
    return path + "/" + name;
  }
  std::string path;
};

// The shipped design's file with one line replaced (key = value of that key's line).
std::string WithLine(const std::string& key, const std::string& line) {
  std::istringstream in(Read(kGainsFile));
  std::string out;
  for (std::string l; std::getline(in, l);) {
    out += (l.rfind(key + " =", 0) == 0 ? line : l) + "\n";
  }
  return out;
}

// ---- The gains file -------------------------------------------------------------------------

TEST(ClippedGainsFileTest, TheDesignsFileLoadsAndItsObserverIsStable) {
  ClippedOptimalGains g;
  std::string error;
  ASSERT_TRUE(platform::LoadClippedOptimalGains(kGainsFile, &g, &error)) << error;
  EXPECT_TRUE(g.IsValid(nullptr));
  EXPECT_EQ(g.v_max, 2.25);
  EXPECT_EQ(g.v_min, 0.0);
  EXPECT_NE(g.k[0], 0.0);
  EXPECT_NE(g.l[0], 0.0);
  EXPECT_TRUE(platform::ClippedObserverStable(g));
  // Without the observer gain the error dynamics are the frame's own (lightly damped: stable
  // too); a growing ad is not.
  ClippedOptimalGains grow = g;
  for (double& l : grow.l) l = 0.0;
  for (int i = 0; i < 6; ++i) grow.ad[i * 6 + i] *= 1.001;
  EXPECT_FALSE(platform::ClippedObserverStable(grow));
  ClippedOptimalGains identity;
  for (int i = 0; i < 6; ++i) identity.ad[i * 6 + i] = 1.0;  // rho = 1: not asymptotically
  EXPECT_FALSE(platform::ClippedObserverStable(identity));
}

TEST(ClippedGainsFileTest, EveryBadFieldIsRefusedWithItsLine) {
  struct Case {
    std::string text;
    const char* where;   // "g.toml:LINE:"
    const char* reason;  // part of the message
  };
  std::string diag2 = "ad = [";  // 2 on the diagonal, and no observer gain: unstable
  for (int i = 0; i < 36; ++i) diag2 += std::string(i ? ", " : "") + (i % 7 == 0 ? "2" : "0");
  diag2 += "]";
  std::string unstable;
  {
    std::istringstream in(WithLine("ad", diag2));
    for (std::string l; std::getline(in, l);) {
      unstable +=
          (l.rfind("l =", 0) == 0 ? "l = [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]"
                                  : l) +
          "\n";
    }
  }
  const Case cases[] = {
      {WithLine("ad", "ad = [1, 2, 3]"), "g.toml:3:", "'ad' must be a list of 36 numbers (has 3)"},
      {WithLine("bd", "bd = 4"), "g.toml:4:", "'bd' must be a list of 6 numbers"},
      {WithLine("k", "k = [1, 2, 3, 4, 5, \"x\"]"),
       "g.toml:8:", "'k' element 6 must be a finite number"},
      {WithLine("dy", "dy = [1, nan, 3]"), "g.toml:6:", "'dy' element 2 must be a finite number"},
      {WithLine("l", ""), "g.toml:2:", "has no 'l' (18 numbers)"},
      {WithLine("v_max", "v_max = \"high\""), "g.toml:9:", "'v_max' must be a number"},
      {WithLine("v_min", "v_min = 3.0"), "g.toml:10:", "v_min must not exceed v_max"},
      {WithLine("v_min", "v_min = 0.0\ngain = 2"), "g.toml:11:", "unknown key 'gain'"},
      {WithLine("v_max", ""), "g.toml:2:", "has no 'v_max'"},
      {Read(kGainsFile) + "[other]\nx = 1\n", "g.toml:11:", "unexpected 'other'"},
      {"# nothing\n", "g.toml:1:", "no table [control.clipped_optimal]"},
      {"[control.other]\nx = 1\n", "g.toml:1:", "unexpected 'control.other'"},
      {"[control.clipped_optimal\n", "g.toml:1:", ""},
      {unstable, "g.toml:7:", "the observer is unstable"}};
  TempDir dir;
  for (const Case& k : cases) {
    SCOPED_TRACE(k.text.substr(0, 200));
    ClippedOptimalGains g;
    std::string error;
    EXPECT_FALSE(platform::ParseClippedOptimalGains(k.text, "g.toml", &g, &error));
    EXPECT_EQ(error.rfind(k.where, 0), 0U) << error;
    EXPECT_NE(error.find(k.reason), std::string::npos) << error;
  }
  // A missing file and a directory: refused with the path.
  ClippedOptimalGains g;
  std::string error;
  EXPECT_FALSE(platform::LoadClippedOptimalGains(dir.path + "/none.toml", &g, &error));
  EXPECT_NE(error.find("none.toml"), std::string::npos) << error;
  EXPECT_FALSE(platform::LoadClippedOptimalGains(dir.path, &g, &error));
  EXPECT_NE(error.find("directory"), std::string::npos) << error;
}

// ---- The configuration -----------------------------------------------------------------------

const char* kCanInputs =
    "inputs = [\"velocity\", \"force\", \"floor_acceleration_1\", \"floor_acceleration_2\", "
    "\"floor_acceleration_3\"]\n";

std::string CanConfig(const std::string& inputs, const std::string& gains = kGainsFile) {
  return "[control]\nlaw = \"clipped-optimal\"\n[clipped_optimal]\ngains = \"" + gains +
         "\"\n[can]\n" + inputs + "outputs = [\"command\"]\nlocal_bus = \"/tmp/x\"\n";
}

TEST(ClippedConfigTest, TheLawWithItsGainsAndInputsIsAccepted) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(platform::ParseConfig(CanConfig(kCanInputs), "fw.toml", &c, &error)) << error;
  EXPECT_EQ(c.controller.law.mode, ControlMode::kClippedOptimal);
  EXPECT_EQ(c.controller.law.clipped_command, ClippedCommand::kClipped);
  ASSERT_TRUE(c.controller.clipped_gains_loaded);
  ClippedOptimalGains g;
  ASSERT_TRUE(platform::LoadClippedOptimalGains(kGainsFile, &g, &error));
  for (int i = 0; i < 36; ++i) EXPECT_EQ(c.controller.clipped_gains.ad[i], g.ad[i]);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(c.controller.clipped_gains.k[i], g.k[i]);
  Controller controller;
  EXPECT_EQ(controller.Configure(test::DemoDamperTable(), c.controller), Error::kOk);
  // The inverse command; the dry run (no bus) needs only the gains.
  platform::FirmwareConfig d;
  ASSERT_TRUE(
      platform::ParseConfig("[control]\nlaw = \"clipped-optimal\"\n[clipped_optimal]\ngains = \"" +
                                kGainsFile + "\"\ncommand = \"inverse\"\n",
                            "fw.toml", &d, &error))
      << error;
  EXPECT_EQ(d.controller.law.clipped_command, ClippedCommand::kInverse);
  // A relative path is relative to the config file.
  TempDir dir;
  dir.Write("g.toml", Read(kGainsFile));
  platform::FirmwareConfig e;
  ASSERT_TRUE(
      platform::ParseConfig(CanConfig(kCanInputs, "g.toml"), dir.path + "/fw.toml", &e, &error))
      << error;
  EXPECT_EQ(e.controller.clipped_gains.l[3], g.l[3]);
}

TEST(ClippedConfigTest, RefusalsNameTheFileLineAndReason) {
  TempDir dir;
  const std::string bad = dir.Write("bad.toml", WithLine("k", "k = [1, 2]"));
  struct Case {
    std::string text;
    const char* message;
  };
  const Case cases[] = {
      {"[control]\nlaw = \"clipped-optimal\"\n",
       "fw.toml:2: law \"clipped-optimal\" needs [clipped_optimal] gains"},
      {CanConfig("inputs = [\"velocity\", \"force\", \"floor_acceleration_1\", "
                 "\"floor_acceleration_3\"]\n"),
       "no bus serves input 'floor_acceleration_2' (law \"clipped-optimal\")"},
      {CanConfig("inputs = [\"velocity\", \"floor_acceleration_1\", \"floor_acceleration_2\", "
                 "\"floor_acceleration_3\"]\n"),
       "no bus serves input 'force' (law \"clipped-optimal\")"},
      {CanConfig(kCanInputs, bad), "fw.toml:4: [clipped_optimal] gains: "},
      {CanConfig(kCanInputs, dir.path + "/missing.toml"), "fw.toml:4: [clipped_optimal] gains: "},
      {"[clipped_optimal]\ncommand = \"bang-bang\"\n",
       "fw.toml:2: 'command' must be one of clipped | inverse"},
      {"[clipped_optimal]\ngains = \"\"\n", "fw.toml:2: 'gains' must not be empty"},
      {"[clipped_optimal]\nweights = 3\n", "fw.toml:2: unknown key 'weights' in [clipped_optimal]"},
      {"[control]\nlaw = \"force\"\n[modbus]\nmode = \"tcp\"\nhost = \"h\"\ninputs = "
       "[\"velocity\", \"demand\", \"floor_acceleration_1\"]\noutputs = [\"command\"]\n",
       "input 'floor_acceleration_1' needs a Modbus device profile"}};
  for (const Case& k : cases) {
    platform::FirmwareConfig c;
    std::string error;
    EXPECT_FALSE(platform::ParseConfig(k.text, "fw.toml", &c, &error)) << k.text;
    EXPECT_NE(error.find(k.message), std::string::npos) << k.text << "\n" << error;
  }
  // The gains file's own line follows.
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_FALSE(platform::ParseConfig(CanConfig(kCanInputs, bad), "fw.toml", &c, &error));
  EXPECT_NE(error.find("bad.toml:8: 'k' must be a list of 6 numbers (has 2)"), std::string::npos)
      << error;
}

TEST(ClippedConfigTest, CtlSetSwitchesToTheLawOnlyWithGainsAndRoutedInputs) {
  std::string error, why;
  platform::FirmwareConfig none;
  ASSERT_TRUE(platform::ParseConfig("[control]\nlaw = \"constant\"\n", "fw.toml", &none, &error))
      << error;
  EXPECT_FALSE(platform::SetParam(&none, "control.law", "clipped-optimal", &why));
  EXPECT_NE(why.find("needs [clipped_optimal] gains"), std::string::npos) << why;
  platform::FirmwareConfig c;
  ASSERT_TRUE(platform::ParseConfig("[control]\nlaw = \"constant\"\n[clipped_optimal]\ngains = \"" +
                                        kGainsFile + "\"\n[can]\n" + kCanInputs +
                                        "outputs = [\"command\"]\nlocal_bus = \"/tmp/x\"\n",
                                    "fw.toml", &c, &error))
      << error;
  EXPECT_TRUE(platform::SetParam(&c, "control.law", "clipped-optimal", &why)) << why;
  EXPECT_TRUE(platform::SetParam(&c, "clipped_optimal.command", "inverse", &why)) << why;
  EXPECT_EQ(c.controller.law.clipped_command, ClippedCommand::kInverse);
  EXPECT_FALSE(platform::SetParam(&c, "clipped_optimal.gains", "other.toml", &why));
  EXPECT_NE(why.find("reload"), std::string::npos) << why;
}

// mrd-firmware's argv with args, behind the emulator's words in a cross build (qemu-user: a
// direct exec of a target binary fails with 127 there). ChildProcess does not search PATH, so
// the emulator is found by /usr/bin/env.
std::vector<std::string> FirmwareArgv(const std::vector<std::string>& args) {
  std::vector<std::string> argv;
  std::istringstream emulator(MRD_TEST_EMULATOR);
  for (std::string w; emulator >> w;) {
    if (argv.empty()) argv.push_back("/usr/bin/env");
    argv.push_back(w);
  }
  argv.push_back(std::string(MRD_BIN_DIR) + "/mrd-firmware");
  argv.insert(argv.end(), args.begin(), args.end());
  return argv;
}

// mrd-firmware itself: a dry run of the law, and a bad gains file stops the start (exit 2).
// Lockstep, so it runs under qemu-user in the cross builds too.
TEST(ClippedConfigTest, TheFirmwareRunsTheLawAndRefusesABadGainsFileWithExit2) {
  TempDir dir;
  const std::string good =
      dir.Write("fw.toml", "[control]\nlaw = \"clipped-optimal\"\n[clipped_optimal]\ngains = \"" +
                               kGainsFile + "\"\ncommand = \"inverse\"\n");
  test::ChildProcess ok(
      FirmwareArgv({"--config", good, "--dry-run", "0.5", "--lockstep", "--json"}));
  ASSERT_EQ(ok.Wait(60.0), 0) << ok.Stderr();
  EXPECT_NE(ok.Stdout().find("\"law\": \"clipped-optimal\""), std::string::npos) << ok.Stdout();
  EXPECT_NE(ok.Stdout().find("\"ticks\": 500"), std::string::npos) << ok.Stdout();
  dir.Write("bad.toml", WithLine("cy", "cy = [1, 2]"));
  const std::string bad =
      dir.Write("fw2.toml",
                "[control]\nlaw = \"clipped-optimal\"\n[clipped_optimal]\ngains = \"bad.toml\"\n");
  test::ChildProcess refused(FirmwareArgv({"--config", bad, "--dry-run", "0.5", "--lockstep"}));
  EXPECT_EQ(refused.Wait(60.0), 2);
  EXPECT_NE(refused.Stderr().find("fw2.toml:4: [clipped_optimal] gains: "), std::string::npos)
      << refused.Stderr();
  EXPECT_NE(refused.Stderr().find("bad.toml:5: 'cy' must be a list of 18 numbers (has 2)"),
            std::string::npos)
      << refused.Stderr();
}

// ---- Through the Controller ------------------------------------------------------------------

// Gains whose estimate is the last measured force: xh1+ = f, f_c = xh1 (k1 = -1).
ClippedOptimalGains LastForceGains() {
  ClippedOptimalGains g;
  g.bd[0] = 1.0;
  g.k[0] = -1.0;
  g.v_max = 2.0;
  g.v_min = 0.5;
  return g;
}

ControllerConfig ClippedConfig(const ClippedOptimalGains& g) {
  ControllerConfig c;
  c.law.mode = ControlMode::kClippedOptimal;
  c.clipped_gains = g;
  c.clipped_gains_loaded = true;
  c.watchdog.max_age_ns = 3 * kMs;
  return c;
}

SensorFrame Frame(std::int64_t t, double force, double a1 = 0.1, double a2 = 0.2, double a3 = 0.3) {
  SensorFrame f;
  f[Input::kVelocity] = {2.0, t};
  f[Input::kForce] = {force, t};
  f[FloorAcceleration(0)] = {a1, t};
  f[FloorAcceleration(1)] = {a2, t};
  f[FloorAcceleration(2)] = {a3, t};
  return f;
}

TEST(ClippedControllerTest, ConfigureNeedsLoadedValidGains) {
  ControllerConfig c;
  c.law.mode = ControlMode::kClippedOptimal;
  Controller controller;
  EXPECT_EQ(controller.Configure(test::DemoDamperTable(), c), Error::kOutOfRange);
  c = ClippedConfig(LastForceGains());
  c.clipped_gains.k[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(controller.Configure(test::DemoDamperTable(), c), Error::kOutOfRange);
  c.clipped_gains.k[2] = 0.0;
  c.clipped_gains.v_min = 3.0;  // above v_max
  EXPECT_EQ(controller.Configure(test::DemoDamperTable(), c), Error::kOutOfRange);
  // A valid design for two dampers: the controller drives one and refuses it.
  c = ClippedConfig(LastForceGains());
  c.clipped_gains.dampers = 2;
  EXPECT_TRUE(c.clipped_gains.IsValid(nullptr));
  EXPECT_EQ(controller.Configure(test::DemoDamperTable(), c), Error::kOutOfRange);
  c.clipped_gains.dampers = 4;  // beyond kMaxDampers
  EXPECT_FALSE(c.clipped_gains.IsValid(nullptr));
  EXPECT_EQ(controller.Configure(test::DemoDamperTable(), ClippedConfig(LastForceGains())),
            Error::kOk);
}

TEST(ClippedControllerTest, TheClippedRuleByHand) {
  Controller controller;
  ControllerConfig config = ClippedConfig(LastForceGains());
  config.e_max = 1.8;  // the gains' v_max 2.0 is clamped to E_max
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), config), Error::kOk);
  std::int64_t t = 10 * kMs;
  // k = 0: estimate at rest, f_c = 0: (0 - 10) 10 < 0: v_min.
  ControllerOutput out = controller.Update(Frame(t, 10.0), IoStatus::kOk, false, t, 1e-3);
  ASSERT_FALSE(out.safe);
  EXPECT_DOUBLE_EQ(out.volts, 0.5);
  EXPECT_DOUBLE_EQ(out.force_demand, 0.0);
  EXPECT_FALSE(out.force_law);
  // k = 1: f_c = 10 (last force), f = 5: (10 - 5) 5 > 0: the force must grow: v_max (clamped).
  t += kMs;
  out = controller.Update(Frame(t, 5.0), IoStatus::kOk, false, t, 1e-3);
  EXPECT_DOUBLE_EQ(out.force_demand, 10.0);
  EXPECT_NEAR(out.volts, 1.8, 1e-6);
  EXPECT_NEAR(controller.law_volts(), 2.0, 1e-6);  // the rule's own voltage
  // k = 2: f_c = 5, f = 20: (5 - 20) 20 < 0: v_min.
  t += kMs;
  out = controller.Update(Frame(t, 20.0), IoStatus::kOk, false, t, 1e-3);
  EXPECT_DOUBLE_EQ(out.force_demand, 5.0);
  EXPECT_DOUBLE_EQ(out.volts, 0.5);
  // k = 3: f_c = 20, f = -4: (20 + 4)(-4) < 0: v_min; k = 4: f_c = -4, f = -1: (-3)(-1) > 0.
  t += kMs;
  EXPECT_DOUBLE_EQ(controller.Update(Frame(t, -4.0), IoStatus::kOk, false, t, 1e-3).volts, 0.5);
  t += kMs;
  EXPECT_NEAR(controller.Update(Frame(t, -1.0), IoStatus::kOk, false, t, 1e-3).volts, 1.8, 1e-6);
}

TEST(ClippedControllerTest, TheInverseCommandIsTheForceLawAtTheDesiredForce) {
  ClippedOptimalGains g = LastForceGains();
  ControllerConfig clipped = ClippedConfig(g);
  clipped.law.clipped_command = ClippedCommand::kInverse;
  ControllerConfig force;
  force.watchdog.max_age_ns = 3 * kMs;
  Controller a, b;
  ASSERT_EQ(a.Configure(test::DemoDamperTable(), clipped), Error::kOk);
  ASSERT_EQ(b.Configure(test::DemoDamperTable(), force), Error::kOk);
  const double forces[] = {0.0, 150.0, -80.0, 300.0, 20.0, -400.0, 90.0};
  std::int64_t t = 10 * kMs;
  double demand = 0.0;  // f_c of the clipped law this period: the last force
  int differs_from_rule = 0;
  for (int k = 0; k < 7; ++k) {
    const double f = forces[k];
    SensorFrame fa = Frame(t, f);
    fa[Input::kVelocity].value = 5.0 * std::sin(0.7 * k);
    SensorFrame fb = fa;
    fb[Input::kDemand] = {demand, t};
    const ControllerOutput oa = a.Update(fa, IoStatus::kOk, false, t, 1e-3);
    const ControllerOutput ob = b.Update(fb, IoStatus::kOk, false, t, 1e-3);
    ASSERT_FALSE(oa.safe);
    EXPECT_TRUE(oa.force_law);
    EXPECT_DOUBLE_EQ(oa.force_demand, demand);
    EXPECT_DOUBLE_EQ(oa.volts, ob.volts) << k;
    EXPECT_EQ(oa.reachable, ob.reachable) << k;
    const double rule = (demand - f) * f > 0.0 ? 2.0 : 0.5;
    if (std::fabs(oa.volts - rule) > 1e-6) ++differs_from_rule;
    demand = f;
    t += kMs;
  }
  EXPECT_GT(differs_from_rule, 0);  // it is not the clipped rule
}

TEST(ClippedControllerTest, StaleOrNaNInputsEnterTheSafeStateAndRestartTheEstimate) {
  for (int which = 0; which < 4; ++which) {
    SCOPED_TRACE(which);
    Controller controller;
    ASSERT_EQ(controller.Configure(test::DemoDamperTable(), ClippedConfig(LastForceGains())),
              Error::kOk);
    std::int64_t t = 10 * kMs;
    EXPECT_FALSE(controller.Update(Frame(t, 10.0), IoStatus::kOk, false, t, 1e-3).safe);
    EXPECT_EQ(controller.clipped_optimal().estimate()[0], Real(10));
    const auto field = [which](SensorFrame* f) -> Stamped* {
      if (which == 3) return &(*f)[Input::kForce];
      return &(*f)[FloorAcceleration(which)];
    };
    for (int bad = 0; bad < 2; ++bad) {
      t += kMs;
      SensorFrame f = Frame(t, 7.0);
      if (bad == 0) {
        field(&f)->stamp_ns = t - 3 * kMs - 1;
      } else {
        field(&f)->value = std::numeric_limits<double>::quiet_NaN();
      }
      const ControllerOutput out = controller.Update(f, IoStatus::kOk, false, t, 1e-3);
      EXPECT_TRUE(out.safe);
      EXPECT_NE(
          out.causes & Watchdog::Bit(bad == 0 ? FaultCause::kStaleSensor : FaultCause::kNonFinite),
          0U);
      EXPECT_EQ(controller.clipped_optimal().estimate()[0], Real(0));  // restarted
    }
  }
  // The other laws do not read the floor accelerations.
  ControllerConfig constant;
  constant.law.mode = ControlMode::kConstantVoltage;
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), constant), Error::kOk);
  SensorFrame f;
  f[Input::kVelocity] = {3.0, 0};
  EXPECT_EQ(controller.Update(f, IoStatus::kOk, false, 0, 1e-3).causes, 0U);
}

TEST(ClippedControllerTest, TheObserverRunsInTheSafeStateOnValidInputs) {
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), ClippedConfig(LastForceGains())),
            Error::kOk);
  std::int64_t t = 10 * kMs;
  // A driver fault: safe state, but the inputs are valid: the estimate follows them.
  const ControllerOutput out = controller.Update(Frame(t, 42.0), IoStatus::kOk, true, t, 1e-3);
  EXPECT_TRUE(out.safe);
  EXPECT_EQ(out.volts, 0.0);
  EXPECT_EQ(controller.clipped_optimal().estimate()[0], Real(42));
}

TEST(ClippedControllerTest, RetuneIntoTheLawStartsFromRestAndNeedsGains) {
  Controller controller;
  ControllerConfig config;
  config.law.mode = ControlMode::kConstantVoltage;
  config.watchdog.max_age_ns = 3 * kMs;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), config), Error::kOk);
  ControllerConfig next = config;
  next.law.mode = ControlMode::kClippedOptimal;
  EXPECT_EQ(controller.Retune(next), Error::kOutOfRange);  // no gains
  next.clipped_gains = LastForceGains();
  next.clipped_gains_loaded = true;
  ASSERT_EQ(controller.Retune(next), Error::kOk);
  std::int64_t t = 10 * kMs;
  const ControllerOutput out = controller.Update(Frame(t, 10.0), IoStatus::kOk, false, t, 1e-3);
  EXPECT_DOUBLE_EQ(out.force_demand, 0.0);  // from rest
  EXPECT_DOUBLE_EQ(out.volts, 0.5);
  EXPECT_EQ(controller.clipped_optimal().estimate()[0], Real(10));
}

}  // namespace
}  // namespace mrd::firmware
