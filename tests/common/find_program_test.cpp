// FindProgram (find_program.hpp): the PATH search used instead of posix_spawnp.
#include "mrd/common/find_program.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>

namespace mrd::common {
namespace {

class FindProgramTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/mrd-findprog-XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    const char* old = std::getenv("PATH");
    old_path_ = old != nullptr ? old : "";
  }
  void TearDown() override {
    setenv("PATH", old_path_.c_str(), 1);
    (void)std::system(("rm -rf " + dir_).c_str());
  }
  std::string Make(const std::string& name, mode_t mode) {
    const std::string p = dir_ + "/" + name;
    std::ofstream(p) << "#!/bin/sh\n";
    chmod(p.c_str(), mode);
    return p;
  }
  std::string dir_, old_path_;
};

TEST_F(FindProgramTest, SkipsMissingAndNonExecutableEntriesAndFindsTheFirstExecutable) {
  Make("tool", 0644);  // not executable: skipped
  const std::string sub = dir_ + "/sub";
  mkdir(sub.c_str(), 0755);
  const std::string exe = sub + "/tool";
  std::ofstream(exe) << "#!/bin/sh\n";
  chmod(exe.c_str(), 0755);
  setenv("PATH", ("/nonexistent-dir:" + dir_ + ":" + sub).c_str(), 1);
  EXPECT_EQ(FindProgram("tool"), exe);
  EXPECT_EQ(FindProgram("no-such-tool"), "");
}

TEST_F(FindProgramTest, ADirectoryWithTheNameIsNotAProgram) {
  mkdir((dir_ + "/tool").c_str(), 0755);
  setenv("PATH", dir_.c_str(), 1);
  EXPECT_EQ(FindProgram("tool"), "");
}

TEST_F(FindProgramTest, UnsetPathSearchesUsrBinAndBin) {
  unsetenv("PATH");
  const std::string sh = FindProgram("sh");
  EXPECT_TRUE(sh == "/usr/bin/sh" || sh == "/bin/sh") << sh;
}

}  // namespace
}  // namespace mrd::common
