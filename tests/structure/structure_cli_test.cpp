// mrd-structure through the executable: help, modes, design --out, the study's refusals.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;

const std::string kBin = std::string(MRD_BIN_DIR) + "/mrd-structure";

std::string TempDir() {
  char dir[] = "/tmp/mrd-structure-XXXXXX";
  return mkdtemp(dir) != nullptr ? dir : "/tmp";
}

void Write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(StructureCliTest, HelpAndModes) {
  ChildProcess help({kBin, "study", "--help"});
  EXPECT_EQ(help.Wait(30), 0);
  EXPECT_NE(help.Stdout().find("--time-scale"), std::string::npos);
  ChildProcess modes({kBin, "modes"});
  EXPECT_EQ(modes.Wait(30), 0);
  EXPECT_NE(modes.Stdout().find("mode 1: 5.457 Hz"), std::string::npos) << modes.Stdout();
}

TEST(StructureCliTest, DesignWritesTheGainsAtomically) {
  const std::string dir = TempDir();
  ChildProcess p({kBin, "design", "--out", dir + "/gains.toml"});
  ASSERT_EQ(p.Wait(60), 0) << p.Stderr();
  std::ifstream in(dir + "/gains.toml");
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_NE(s.str().find("[control.clipped_optimal]"), std::string::npos);
  EXPECT_NE(s.str().find("\nk = ["), std::string::npos);
  EXPECT_FALSE(std::ifstream(dir + "/gains.toml.tmp").good());
}

TEST(StructureCliTest, BadInputIsRefusedWithExit2) {
  const std::string dir = TempDir();
  Write(dir + "/header.csv", "# c\ntime,acc\n0,0\n");
  Write(dir + "/text.csv", "t_s,ag_g\n0,0.1\n0.02,abc\n");
  Write(dir + "/uneven.csv", "t_s,ag_g\n0,0.1\n0.02,0.2\n0.05,0.1\n");
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  const Case cases[] = {
      {{"--record", dir + "/missing.csv"}, dir + "/missing.csv: cannot open"},
      {{"--record", dir + "/header.csv"}, dir + "/header.csv:2: expected the header t_s,ag_g"},
      {{"--record", dir + "/text.csv"}, dir + "/text.csv:3: expected 't_s,ag_g' numbers"},
      {{"--record", dir + "/uneven.csv"}, dir + "/uneven.csv:4: samples are not equally spaced"},
      {{"--damper", "nope"}, "--damper: unknown preset 'nope'"},
      {{"--period", "-1"}, "period"},
      {{"--time-scale", "abc"}, "time-scale"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> argv = {kBin, "study"};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const std::string out = dir + "/table.md";
    argv.push_back("--out");
    argv.push_back(out);
    ChildProcess p(argv);
    EXPECT_EQ(p.Wait(60), 2) << c.message;
    EXPECT_NE(p.Stderr().find(c.message), std::string::npos) << p.Stderr();
    EXPECT_FALSE(std::ifstream(out).good()) << "nothing written: " << c.message;
  }
}

}  // namespace
