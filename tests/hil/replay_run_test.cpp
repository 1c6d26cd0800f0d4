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
  EXPECT_DOUBLE_EQ(
      r.j["tracking"]["reachable_share"].get<double>(),
      r.j["tracking"]["reachable_steps"].get<double>() / r.j["tracking"]["steps"].get<double>());
  std::system(("rm -rf " + dir).c_str());
}

// The reachable error scores only the steps whose demand the damper can give: below the least
// share (the default 0.25 here; the scenario states 0.15 with its all-steps score) the measured
// run's ~20 % fails, saying so and giving the error over all steps, instead of passing on a
// fifth of the run.
TEST(ReplayRunTest, ReachableErrorOverTooFewStepsFailsWithTheReason) {
  const std::string dir = TempDirPath();
  const HilResult r = Hil({std::string(MRD_SOURCE_DIR) + "/hil/scenarios/nees-damper.toml", "--set",
                           "pass.min_reachable_share=0.25", "--out", dir});
  ASSERT_EQ(r.status, 1) << r.err;
  EXPECT_FALSE(r.j["pass"].get<bool>());
  const double share = r.j["tracking"]["reachable_share"].get<double>();
  EXPECT_LT(share, 0.25);
  EXPECT_GT(share, 0.05);
  EXPECT_LE(r.j["tracking"]["error_reachable"].get<double>(), 0.05);  // the score alone passes
  bool named = false;
  for (const auto& f : r.j["failures"]) {
    const std::string why = f.get<std::string>();
    named = named || (why.find("reachable demands on ") != std::string::npos &&
                      why.find("< min_reachable_share 25 %") != std::string::npos &&
                      why.find("error over all steps") != std::string::npos);
  }
  EXPECT_TRUE(named) << r.j["failures"].dump();
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
