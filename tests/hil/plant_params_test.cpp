// [plant] params files, [plant.spencer] overrides, [excitation] kind = "replay" and
// [firmware] table in scenarios: what they load and every refusal (FILE:LINE: reason).
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "mrd/hil/plants/replay.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/params/spencer_params_file.hpp"

namespace mrd::hil {
namespace {

class PlantParamsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/mrd_plant_params_XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { std::system(("rm -rf " + dir_).c_str()); }
  std::string Write(const std::string& name, const std::string& text) {
    const std::string p = dir_ + "/" + name;
    std::ofstream(p) << text;
    return p;
  }
  // Loads a scenario; "" on success, else the error.
  std::string Load(const std::string& text, Scenario* s) {
    std::string error;
    return LoadScenario(Write("s.toml", text), s, &error) ? "" : error;
  }
  void ExpectRefused(const std::string& text, const std::string& fragment) {
    Scenario s;
    const std::string e = Load(text, &s);
    EXPECT_NE(e.find(fragment), std::string::npos) << "error: '" << e << "' for:\n" << text;
  }
  std::string dir_;
};

TEST_F(PlantParamsTest, ParamsFileAndOverrides) {
  Write("p.toml", "preset = \"spencer1997\"\nc0a = 12.5\neta = 150\n");
  Scenario s;
  ASSERT_EQ(Load("[plant]\nparams = \"p.toml\"\n[plant.spencer]\nk1 = 7\n", &s), "");
  EXPECT_DOUBLE_EQ(s.damper.c0a, 12.5);
  EXPECT_DOUBLE_EQ(s.damper.eta, 150.0);
  EXPECT_DOUBLE_EQ(s.damper.gamma, 363.0);  // from the file's preset
  EXPECT_DOUBLE_EQ(s.damper.k1, 7.0);       // the override
  EXPECT_EQ(s.params_file, dir_ + "/p.toml");
}

TEST_F(PlantParamsTest, PresetWithOverridesAndQuarterCar) {
  Scenario s;
  ASSERT_EQ(Load("duration_s = 3\n[plant]\nmodel = \"quarter-car\"\npreset = \"paper\"\n"
                 "[plant.spencer]\nc1a = 400\n",
                 &s),
            "");
  EXPECT_TRUE(s.quarter_car);
  EXPECT_DOUBLE_EQ(s.damper.c1a, 400.0);
  EXPECT_DOUBLE_EQ(s.damper.c0a, SpencerParams::Paper().c0a);
}

TEST_F(PlantParamsTest, DefaultIsThePaperPreset) {
  Scenario s;
  ASSERT_EQ(Load("name = \"x\"\n", &s), "");
  EXPECT_DOUBLE_EQ(s.damper.alpha_b, SpencerParams::Paper().alpha_b);
}

TEST_F(PlantParamsTest, BadParamsFiles) {
  const auto refused = [&](const std::string& file, const std::string& fragment) {
    Write("bad.toml", file);
    ExpectRefused("[plant]\nparams = \"bad.toml\"\n", fragment);
  };
  refused("c0a = 1\nbogus = 2\n", "bad.toml:2: unknown key 'bogus'");
  refused("c0a = 1\nc0b = -3\n", "bad.toml:2: invalid parameter 'c0b': must be >= 0");
  refused("n = 0.5\n", "bad.toml:1: invalid parameter 'n': must be in [1, 10]");
  refused("c1a = 0\n", "bad.toml:1: invalid parameter 'c1a': must be > 0");
  refused("eta = \"fast\"\n", "bad.toml:1: 'eta' must be a number");
  refused("eta = true\n", "bad.toml:1: 'eta' must be a number");
  refused("eta = 1\nc0a = = 2\n", "bad.toml:2:");
  refused("preset = \"x\"\n", "bad.toml:1: unknown preset 'x'");
  ExpectRefused("[plant]\nparams = \"missing.toml\"\n", "missing.toml");
}

TEST_F(PlantParamsTest, BadOverridesAndCombinations) {
  Write("p.toml", "c0a = 10\n");
  ExpectRefused("[plant]\n[plant.spencer]\nc0a = 1\nwhat = 2\n",
                "s.toml:4: unknown key 'what' in [plant.spencer]");
  ExpectRefused("[plant]\n[plant.spencer]\nalpha_a = -1\n",
                "s.toml:3: invalid parameter 'alpha_a'");
  ExpectRefused("[plant]\n[plant.spencer]\nn = 0.9\n", "s.toml:3: invalid parameter 'n'");
  ExpectRefused("[plant]\n[plant.spencer]\nk0 = \"x\"\n", "s.toml:3: 'k0' in [plant.spencer]");
  ExpectRefused("[plant]\npreset = \"paper\"\nparams = \"p.toml\"\n",
                "params and preset exclude each other");
  ExpectRefused("[plant]\nspencer = 3\n", "s.toml:2: [plant.spencer] must be a table");
}

TEST(SpencerParamsText, RoundTrips) {
  SpencerParams p = SpencerParams::Spencer1997();
  p.x0 = -1.0 / 3.0;
  p.n = 1.2345678901234567;
  const std::string path = "/tmp/mrd_params_roundtrip.toml";
  std::ofstream(path) << params::SpencerParamsText(p, "a header\nsecond line");
  SpencerParams q;
  params::ParamsError e;
  ASSERT_TRUE(params::LoadSpencerParamsFile(path, &q, &e)) << e.line << ": " << e.reason;
  EXPECT_EQ(q.x0, p.x0);
  EXPECT_EQ(q.n, p.n);
  EXPECT_EQ(q.alpha_b, p.alpha_b);
  std::remove(path.c_str());
}

TEST_F(PlantParamsTest, ReplayScenarioKeys) {
  Write("run.csv", "t,x,v,E,f\n0,0,0,0,0\n0.001,0.1,1,1,10\n0.002,0.2,1,2,20\n");
  Scenario s;
  ASSERT_EQ(Load("[excitation]\nkind = \"replay\"\nfile = \"run.csv\"\n[control]\n"
                 "law = \"open-loop\"\n[pass]\nmin_replay_fit = 90\n",
                 &s),
            "");
  EXPECT_EQ(s.excitation, ExcitationKind::kReplay);
  EXPECT_EQ(s.csv_file, dir_ + "/run.csv");
  ASSERT_TRUE(s.min_replay_fit.has_value());
  EXPECT_DOUBLE_EQ(*s.min_replay_fit, 90.0);
  // Open loop: the demand carries E of the next row in mV; f is kept for the score.
  Trace t;
  ReplayRun run;
  std::string error;
  ASSERT_TRUE(LoadReplay(s.csv_file, true, "f", &t, &run, &error)) << error;
  ASSERT_EQ(t.demand.size(), 3u);
  EXPECT_DOUBLE_EQ(t.demand[0], 1000.0);
  EXPECT_DOUBLE_EQ(t.demand[1], 2000.0);
  EXPECT_DOUBLE_EQ(t.demand[2], 2000.0);
  EXPECT_DOUBLE_EQ(run.f[2], 20.0);
  ASSERT_TRUE(LoadReplay(s.csv_file, false, "f", &t, &run, &error)) << error;
  EXPECT_DOUBLE_EQ(t.demand[1], 10.0);  // force law: the measured f
}

TEST_F(PlantParamsTest, BadReplay) {
  Write("run.csv", "t,x,v,E,f\n0,0,0,0,0\n0.001,0.1,1,1,10\n");
  ExpectRefused("[excitation]\nkind = \"replay\"\n", "s.toml:2: kind = \"replay\" needs 'file'");
  ExpectRefused("[excitation]\nkind = \"periodic\"\n[control]\nlaw = \"open-loop\"\n",
                "s.toml:4: law \"open-loop\" needs [excitation] kind = \"replay\"");
  ExpectRefused(
      "[excitation]\nkind = \"replay\"\nfile = \"run.csv\"\n[control]\n"
      "law = \"open-loop\"\n[pass]\nmax_error_reachable = 0.1\n",
      "law \"open-loop\" tracks no force");
  ExpectRefused("[pass]\nmin_replay_fit = 90\n", "s.toml:2: min_replay_fit needs");
  ExpectRefused("[firmware]\ntable = \"none.bin\"\n", "s.toml:2: [firmware] table");
  Trace t;
  ReplayRun run;
  std::string error;
  const std::string no_e = Write("noe.csv", "t,x,v,f\n0,0,0,0\n0.001,0,0,0\n");
  EXPECT_FALSE(LoadReplay(no_e, true, "f", &t, &run, &error));
  EXPECT_NE(error.find("noe.csv:1: a replay file needs columns x, v, E and f"), std::string::npos)
      << error;
  EXPECT_NE(error.find("missing 'E'"), std::string::npos) << error;
  const std::string no_xf = Write("noxf.csv", "t,v,E\n0,0,0\n0.001,0,0\n");
  EXPECT_FALSE(LoadReplay(no_xf, false, "f", &t, &run, &error));
  EXPECT_NE(error.find("missing 'x', 'f'"), std::string::npos) << error;
  const std::string bad_row = Write("badrow.csv", "t,x,v,E,f\n0,0,0,0,0\n0.001,0,zz,0,0\n");
  EXPECT_FALSE(LoadReplay(bad_row, false, "f", &t, &run, &error));
  EXPECT_NE(error.find("badrow.csv:3:"), std::string::npos) << error;
}

}  // namespace
}  // namespace mrd::hil
