// Conformance (labels conformance, hardening, hil): mrd-hil run on odd inputs. A folder is no
// scenario (it ran a default scenario and reported PASS), a FIFO is refused without blocking,
// and an excitation file that is not a regular file (/dev/zero grew to 8 GB in 4 s) is
// refused before reading. NaN options, a folder as plant parameters, a table the firmware
// would refuse and a trace at another rate are refused up front (exit 2, nothing written); a
// run with nothing to score the tracking error on, or an absurd demand, does not PASS.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <string>

#include "host/test_util.hpp"

namespace mrd::test {
namespace {

// mrd-hil run ARGS under `timeout` and a 1 GB address-space limit: a command that blocks shows
// as status 124, one that reads without bound dies instead of eating the machine.
CommandResult HilRun(const std::string& args) {
  return test::Run("(ulimit -v 1000000; timeout 60 " + Bin("mrd-hil") + " run " + args +
                   " </dev/null)");
}

CommandResult Hil(const std::string& args) {
  return test::Run("(ulimit -v 1000000; timeout 60 " + Bin("mrd-hil") + " " + args +
                   " </dev/null)");
}

const std::string kScenarios = std::string(MRD_SOURCE_DIR) + "/hil/scenarios/";

TEST(HilInputsConformance, AFolderIsNoScenario) {
  TempDir dir;
  const std::string folder = dir.File("scenarios");
  std::filesystem::create_directory(folder);
  const CommandResult r = HilRun(folder + " --out " + dir.File("out"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_EQ(r.output.find("PASS"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("is a directory, not a regular file"), std::string::npos) << r.output;
}

TEST(HilInputsConformance, AFifoScenarioIsRefusedWithoutBlocking) {
  TempDir dir;
  const std::string fifo = dir.File("scenario.toml");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const CommandResult r = HilRun(fifo + " --out " + dir.File("out"));
  EXPECT_EQ(r.status, 2) << r.output;  // 124: blocked until `timeout`
  EXPECT_NE(r.output.find("is a FIFO, not a regular file"), std::string::npos) << r.output;
}

TEST(HilInputsConformance, AnExcitationThatIsNotARegularFileIsRefused) {
  TempDir dir;
  const std::string fifo = dir.File("trace.csv");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& file : {std::string("/dev/zero"), fifo}) {
    const std::string scenario = dir.Write(
        "csv.toml", "name = \"csv\"\nduration_s = 0.1\n[excitation]\nkind = \"csv\"\nfile = \"" +
                        file + "\"\n");
    const CommandResult r = HilRun(scenario + " --out " + dir.File("out"));
    EXPECT_EQ(r.status, 2) << file << ": " << r.output;
    EXPECT_NE(r.output.find(file + ": is a"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(", not a regular file"), std::string::npos) << r.output;
  }
}

TEST(HilInputsConformance, NotANumberIsRefusedByEveryNumberOption) {
  TempDir dir;
  const struct {
    std::string args, flag;
  } cases[] = {
      {"bench --seconds nan", "--seconds"},
      {"serve --port can=" + dir.File("bus.sock") + " --duration nan", "--duration"},
      {"serve --port can=" + dir.File("bus.sock") + " --duration 1 --amplitude inf", "--amplitude"},
      {"run " + kScenarios + "force-periodic.toml --command-timeout nan", "--command-timeout"},
      {"study --scenario " + kScenarios + "quarter-car-skyhook.toml --duration nan", "--duration"},
  };
  for (const auto& c : cases) {
    const CommandResult r = Hil(c.args);
    EXPECT_EQ(r.status, 2) << c.args << ": " << r.output;
    EXPECT_NE(r.output.find(c.flag + ": Value"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("is not a finite number"), std::string::npos) << r.output;
  }
}

TEST(HilInputsConformance, AFolderIsNoPlantParameterFile) {
  TempDir dir;
  std::filesystem::create_directory(dir.File("pdir"));
  const std::string scenario =
      dir.Write("s.toml", "name = \"p\"\nduration_s = 0.1\n[plant]\nparams = \"pdir\"\n");
  const CommandResult r = HilRun(scenario + " --out " + dir.File("out"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("pdir: is a directory, not a regular file"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("PASS"), std::string::npos) << r.output;
}

TEST(HilInputsConformance, ATableTheFirmwareWouldRefuseIsBadInputAndNothingIsWritten) {
  TempDir dir;
  const std::string table = dir.Write("bad.bin", std::string(4000, 'x'));
  const CommandResult run =
      HilRun(kScenarios + "force-periodic.toml --table " + table + " --out " + dir.File("out"));
  EXPECT_EQ(run.status, 2) << run.output;
  EXPECT_NE(run.output.find(table + ": is 4000 bytes"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("out"))) << "nothing written";
  const CommandResult bench = Hil("bench --seconds 0.2 --table " + table);
  EXPECT_EQ(bench.status, 2) << bench.output;
  EXPECT_NE(bench.output.find(table + ": is 4000 bytes"), std::string::npos) << bench.output;
}

TEST(HilInputsConformance, AnOutputThatIsAFileIsRefused) {
  TempDir dir;
  const std::string file = dir.Write("taken", "x");
  const CommandResult r = HilRun(kScenarios + "force-periodic.toml --out " + file);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--out " + file + ": exists and is not a directory"), std::string::npos)
      << r.output;
}

TEST(HilInputsConformance, ATraceAtAnotherRateOrWithAbsurdValuesIsRefused) {
  TempDir dir;
  const std::string fast = dir.Write("fast.csv", "t,x,v,f\n0,0,0,0\n0.0005,0,1,2\n0.001,0,2,3\n");
  CommandResult r = HilRun(kScenarios + "force-periodic.toml --excitation " + fast);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("fast.csv:3: t steps by 0.000500 s"), std::string::npos) << r.output;
  const std::string huge = dir.Write("huge.csv", "t,x,v,f\n0,0,0,0\n0.001,0,1,1e308\n");
  r = HilRun(kScenarios + "force-periodic.toml --excitation " + huge);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("huge.csv:3: beyond"), std::string::npos) << r.output;
}

TEST(HilInputsConformance, AZeroDemandGivesNoTrackingScoreAndFails) {
  TempDir dir;
  const CommandResult r =
      HilRun(kScenarios + "force-periodic.toml --set excitation.demand_amplitude_n=0 --out " +
             dir.File("out"));
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find(": FAIL"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("all n/a, reachable n/a"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no non-zero demand to score the tracking error on"), std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace mrd::test
