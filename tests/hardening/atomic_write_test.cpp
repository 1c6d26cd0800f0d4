// Issue 14 (hardening), defect 2: the one atomic-write helper of the host.
#include "mrd/host/atomic_write.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "mrd/host/input_error.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::size_t Entries(const std::string& dir) {
  return static_cast<std::size_t>(
      std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

TEST(AtomicWriteTest, ReplacesARegularFileAndLeavesNoTemporary) {
  test::TempDir dir;
  const std::string out = dir.Write("out.txt", "old\n");
  WriteFileAtomic(out, "new\n");
  EXPECT_EQ(Slurp(out), "new\n");
  EXPECT_EQ(Entries(dir.File("")), 1u);
}

TEST(AtomicWriteTest, RefusesEmptyPathsSymlinksAndSpecialFiles) {
  test::TempDir dir;
  EXPECT_THROW(WriteFileAtomic("", "x"), InputError);
  const std::string victim = dir.Write("victim", "precious");
  ASSERT_EQ(symlink(victim.c_str(), dir.File("link").c_str()), 0);
  EXPECT_THROW(WriteFileAtomic(dir.File("link"), "x"), InputError);
  ASSERT_EQ(mkfifo(dir.File("fifo").c_str(), 0600), 0);
  EXPECT_THROW(WriteFileAtomic(dir.File("fifo"), "x"), InputError);
  fs::create_directory(dir.File("sub"));
  EXPECT_THROW(WriteFileAtomic(dir.File("sub"), "x"), InputError);
  EXPECT_EQ(Slurp(victim), "precious");
}

TEST(AtomicWriteTest, MissingDirectoryIsASystemErrorWithItsText) {
  test::TempDir dir;
  try {
    WriteFileAtomic(dir.File("nodir/out"), "x");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("No such file or directory"), std::string::npos)
        << e.what();
  }
}

TEST(AtomicWriteTest, SeveralOutputsAreWrittenAllOrNone) {
  test::TempDir dir;
  EXPECT_ANY_THROW(WriteFilesAtomic({{dir.File("a"), "a"}, {dir.File("nodir/b"), "b"}}));
  EXPECT_EQ(Entries(dir.File("")), 0u);
  WriteFilesAtomic({{dir.File("a"), "a"}, {dir.File("b"), "b"}});
  EXPECT_EQ(Slurp(dir.File("a")), "a");
  EXPECT_EQ(Slurp(dir.File("b")), "b");
}

TEST(AtomicWriteTest, WrittenFilesGetTheUsualPermissions) {
  test::TempDir dir;
  const mode_t old = umask(022);
  WriteFileAtomic(dir.File("out"), "x");
  umask(old);
  struct stat st {};
  ASSERT_EQ(stat(dir.File("out").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0644u);
}

// A child that holds an open temporary file and a staging directory, then gets sig.
void ExpectSignalRemovesTemporaries(int sig) {
  test::TempDir dir;
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const rlimit no_core{0, 0};  // SIGQUIT's default action would dump core
    setrlimit(RLIMIT_CORE, &no_core);
    InstallCleanupHandlers();
    AtomicFile f(dir.File("out.csv"));
    f.Write("partial");
    TempDir staging(dir.File(""), ".rep.report");
    std::ofstream(staging.path() + "/plot.png") << "png";
    raise(sig);
    _exit(0);  // not reached: the handler re-raises with the default action
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(status)) << sig;
  if (WIFSIGNALED(status)) {
    EXPECT_EQ(WTERMSIG(status), sig);
  }
  EXPECT_EQ(Entries(dir.File("")), 0u) << "signal " << sig << " left temporaries";
}

TEST(AtomicWriteTest, TerminatingSignalsRemoveTemporariesAndStagingDirectories) {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE})
    ExpectSignalRemovesTemporaries(sig);
}

}  // namespace
}  // namespace mrd::host
