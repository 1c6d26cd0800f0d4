// Conformance (labels conformance, hardening, hil): mrd-hil run on odd inputs. A folder is no
// scenario (it ran a default scenario and reported PASS), a FIFO is refused without blocking,
// and an excitation file that is not a regular file (/dev/zero grew to 8 GB in 4 s) is
// refused before reading.
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

}  // namespace
}  // namespace mrd::test
