// Replay through mrd-hil run (lockstep, local CAN bus): a generated run replayed open loop
// through the same preset reproduces its force; the shipped nees-damper scenario passes with
// no flags; a replay file without the needed columns is refused (exit 2).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "hil/hil_run.hpp"

namespace mrd::test {
namespace {

std::string TempDirPath() {
  char tmpl[] = "/tmp/mrd_replay_run_XXXXXX";
  return mkdtemp(tmpl) != nullptr ? tmpl : "";
}

TEST(ReplayRunTest, OpenLoopReplayOfAGeneratedRunReproducesItsForce) {
  const std::string dir = TempDirPath();
  ASSERT_FALSE(dir.empty());
  ChildProcess gen({std::string(MRD_BIN_DIR) + "/mrd", "generate", "--profile", "v1", "--seed", "1",
                    "--preset", "spencer1997", "--out", dir + "/v1.csv"});
  ASSERT_EQ(gen.Wait(60.0), 0) << gen.Stderr();
  std::ofstream(dir + "/replay.toml")
      << "duration_s = 3.0\n[plant]\npreset = \"spencer1997\"\n[excitation]\nkind = \"replay\"\n"
         "file = \"v1.csv\"\n[control]\nlaw = \"open-loop\"\n[pass]\nmin_replay_fit = 99.5\n";
  const HilResult r = Hil({dir + "/replay.toml", "--out", dir + "/out"});
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_TRUE(r.j.contains("replay")) << r.j.dump();
  // The only differences: 20 instead of 100 RK4 sub-steps and the firmware's first few
  // start-up periods at 0 V.
  EXPECT_GT(r.j["replay"]["fit_percent"].get<double>(), 99.5) << r.j["replay"].dump();
  EXPECT_LT(r.j["replay"]["rmse_n"].get<double>(), 5.0);
  EXPECT_EQ(r.j["invariant_violations"].get<int>(), 0);
  // Against the other preset the same replay is far off: the score sees the plant.
  std::ofstream(dir + "/other.toml")
      << "duration_s = 3.0\n[plant]\npreset = \"paper\"\n[excitation]\nkind = \"replay\"\n"
         "file = \"v1.csv\"\n[control]\nlaw = \"open-loop\"\n[pass]\nmin_replay_fit = 99.5\n";
  const HilResult other = Hil({dir + "/other.toml", "--out", dir + "/out2"});
  ASSERT_EQ(other.status, 1) << other.err;  // ran, FAIL verdict
  EXPECT_LT(other.j["replay"]["fit_percent"].get<double>(), 95.0);
  EXPECT_FALSE(other.j["pass"].get<bool>());
  std::system(("rm -rf " + dir).c_str());
}

TEST(ReplayRunTest, NeesDamperScenarioPassesWithNoFlags) {
  const std::string dir = TempDirPath();
  const HilResult r =
      Hil({std::string(MRD_SOURCE_DIR) + "/hil/scenarios/nees-damper.toml", "--out", dir});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.j["pass"].get<bool>()) << r.j.dump();
  EXPECT_LE(r.j["tracking"]["error_reachable"].get<double>(), 0.05);
  EXPECT_GT(r.j["tracking"]["reachable_steps"].get<int>(), 1000);
  std::system(("rm -rf " + dir).c_str());
}

TEST(ReplayRunTest, ReplayFileWithoutTheColumnsIsRefused) {
  const std::string dir = TempDirPath();
  std::ofstream(dir + "/run.csv") << "t,x,v,f\n0,0,0,0\n0.001,0,0,0\n";
  std::ofstream(dir + "/s.toml") << "[excitation]\nkind = \"replay\"\nfile = \"run.csv\"\n";
  const HilResult r = Hil({dir + "/s.toml", "--out", dir + "/out"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("run.csv:1: a replay file needs columns x, v, E and f"), std::string::npos)
      << r.err;
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace
}  // namespace mrd::test
