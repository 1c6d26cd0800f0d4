// Conformance (labels conformance, hardening): table files are written whole or not at all.
// --install-table: concurrent installs on one destination serialise (the later one keeps the
// earlier one's table as DEST.prev, nothing is lost), a symlink planted at a staging name is
// never written through; --write-table: a failed write (file-size limit, a full device)
// exits non-zero and leaves no partial file.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "host/test_util.hpp"
#include "mrd/common/table.hpp"

extern char** environ;

namespace mrd::test {
namespace {

namespace fs = std::filesystem;

std::string Firmware() { return Bin("mrd-firmware"); }
std::string FirmwarePath() { return std::string(MRD_BIN_DIR) + "/mrd-firmware"; }

// prefix + n (appended: "x" + std::string trips GCC 12's false -Wrestrict, bug 105329).
std::string Numbered(std::string prefix, std::size_t n) {
  prefix += std::to_string(n);
  return prefix;
}

// Three distinct valid tables: the compiled-in one with E_max 2.25, 2.0 and 1.75 V.
std::vector<std::string> Tables(const TempDir& dir) {
  const std::string base = dir.File("base.bin");
  EXPECT_EQ(test::Run(Firmware() + " --write-table " + base).status, 0);
  const std::string image = FileBytes(base);
  const auto decoded = DecodeTable(std::span<const std::uint8_t>(
      reinterpret_cast<const std::uint8_t*>(image.data()), image.size()));
  EXPECT_TRUE(decoded.ok());
  std::vector<std::string> out;
  for (const double e_max : {2.25, 2.0, 1.75}) {
    CoefficientTable t = decoded.value();
    t.e_max = e_max;
    const auto encoded = EncodeTable(t);
    EXPECT_TRUE(encoded.ok());
    const std::string path = dir.File(Numbered("t", out.size()) + ".bin");
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(encoded.value().data()),
               static_cast<std::streamsize>(encoded.value().size()));
    out.push_back(path);
  }
  return out;
}

// mrd-firmware's argv with args: the emulator's words first in a cross build (qemu-user).
std::vector<std::string> FirmwareArgv(const std::vector<std::string>& args) {
  std::vector<std::string> argv;
  std::istringstream emulator(MRD_TEST_EMULATOR);
  for (std::string w; emulator >> w;) argv.push_back(w);
  argv.push_back(FirmwarePath());
  argv.insert(argv.end(), args.begin(), args.end());
  return argv;
}

// Starts mrd-firmware with args, stdout+stderr to out_path.
pid_t Spawn(const std::vector<std::string>& args, const std::string& out_path) {
  std::vector<std::string> argv = FirmwareArgv(args);
  std::vector<char*> raw;
  for (auto& a : argv) raw.push_back(a.data());
  raw.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  pid_t pid = -1;
  if (posix_spawnp(&pid, raw[0], &fa, nullptr, raw.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  return pid;
}

int ExitStatus(pid_t pid) {
  int st = 0;
  if (waitpid(pid, &st, 0) != pid) return -1;
  return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

std::set<std::string> Entries(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

TEST(TableInstallConformance, ConcurrentInstallsSerialiseAndLoseNothing) {
  TempDir dir;
  const std::vector<std::string> t = Tables(dir);
  const std::string a = FileBytes(t[1]), b = FileBytes(t[2]), original = FileBytes(t[0]);
  int failures = 0;
  for (int round = 0; round < 100 && failures < 5; ++round) {
    const std::string folder = dir.File(Numbered("r", round));
    fs::create_directory(folder);
    const std::string dest = folder + "/table.bin";
    fs::copy_file(t[0], dest);
    const pid_t pa = Spawn({"--install-table", t[1], "--to", dest}, dir.File("a.out"));
    const pid_t pb = Spawn({"--install-table", t[2], "--to", dest}, dir.File("b.out"));
    ASSERT_GT(pa, 0);
    ASSERT_GT(pb, 0);
    const int sa = ExitStatus(pa), sb = ExitStatus(pb);
    const std::string oa = FileBytes(dir.File("a.out")), ob = FileBytes(dir.File("b.out"));
    const std::string now = FileBytes(dest), prev = FileBytes(dest + ".prev");
    // Both said "installed"; the one that ran second is in DEST, the first in DEST.prev.
    const bool ok = sa == 0 && sb == 0 && oa.find("installed as") != std::string::npos &&
                    ob.find("installed as") != std::string::npos &&
                    ((now == a && prev == b) || (now == b && prev == a));
    // No staging file left (the lock file may stay).
    std::set<std::string> left = Entries(folder);
    left.erase("table.bin.lock");
    const std::set<std::string> expected{"table.bin", "table.bin.prev"};
    if (!ok || left != expected) {
      ++failures;
      ADD_FAILURE() << "round " << round << ": exit " << sa << " / " << sb << "\n"
                    << oa << ob << "DEST "
                    << (now == a          ? "A"
                        : now == b        ? "B"
                        : now == original ? "original"
                                          : "other")
                    << ", DEST.prev "
                    << (prev == a          ? "A"
                        : prev == b        ? "B"
                        : prev == original ? "original"
                                           : "other")
                    << ", " << left.size() << " entries";
    }
  }
  EXPECT_EQ(failures, 0);
}

TEST(TableInstallConformance, OneInstallKeepsTheOriginalAsPrevious) {
  TempDir dir;
  const std::vector<std::string> t = Tables(dir);
  for (int round = 0; round < 20; ++round) {
    const std::string dest = dir.File(Numbered("table", round) + ".bin");
    fs::copy_file(t[0], dest);
    // A concurrent check (ExecStartPre) next to the install changes nothing.
    const pid_t install = Spawn({"--install-table", t[1], "--to", dest}, dir.File("i.out"));
    const pid_t check = Spawn({"--check-table", dest, "--rollback"}, dir.File("c.out"));
    EXPECT_EQ(ExitStatus(install), 0) << FileBytes(dir.File("i.out"));
    EXPECT_EQ(ExitStatus(check), 0) << FileBytes(dir.File("c.out"));
    EXPECT_EQ(FileBytes(dest), FileBytes(t[1])) << "round " << round;
    EXPECT_EQ(FileBytes(dest + ".prev"), FileBytes(t[0])) << "round " << round;
  }
}

TEST(TableInstallConformance, SymlinksAtTheOldStagingNamesAreNotFollowed) {
  TempDir dir;
  const std::vector<std::string> t = Tables(dir);
  const std::string dest = dir.File("table.bin");
  ASSERT_EQ(test::Run(Firmware() + " --install-table " + t[0] + " --to " + dest).status, 0);
  const std::string victim = dir.Write("victim.txt", "precious\n");
  fs::create_symlink(victim, dest + ".new");
  fs::create_symlink(victim, dest + ".prev.new");
  const CommandResult r = test::Run(Firmware() + " --install-table " + t[1] + " --to " + dest);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(FileBytes(victim), "precious\n");
  EXPECT_FALSE(fs::is_symlink(dest));
  EXPECT_EQ(FileBytes(dest), FileBytes(t[1]));
  EXPECT_FALSE(fs::is_symlink(dest + ".prev"));
  EXPECT_EQ(FileBytes(dest + ".prev"), FileBytes(t[0]));
  // A destination that is itself a symlink is refused, not written through.
  const std::string link = dir.File("link.bin");
  fs::create_symlink(victim, link);
  const CommandResult s = test::Run(Firmware() + " --install-table " + t[1] + " --to " + link);
  EXPECT_EQ(s.status, 2) << s.output;
  EXPECT_NE(s.output.find("is a symbolic link"), std::string::npos) << s.output;
  EXPECT_EQ(FileBytes(victim), "precious\n");
}

// Runs mrd-firmware --write-table out with a file-size limit of limit bytes (SIGXFSZ
// ignored, so write() fails with EFBIG). Returns the exit status.
int WriteTableWithSizeLimit(const std::string& out, rlim_t limit, std::string* output) {
  const std::string log = out + ".log";
  std::vector<std::string> argv = FirmwareArgv({"--write-table", out});
  std::vector<char*> raw;
  for (auto& a : argv) raw.push_back(a.data());
  raw.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    signal(SIGXFSZ, SIG_IGN);
    const rlimit rl{limit, limit};
    setrlimit(RLIMIT_FSIZE, &rl);
    execvp(raw[0], raw.data());
    _exit(127);
  }
  const int status = ExitStatus(pid);
  *output = FileBytes(log);
  fs::remove(log);
  return status;
}

TEST(TableWriteConformance, AFileSizeLimitFailsTheWriteAndLeavesNoPartialFile) {
  TempDir dir;
  const std::string out = dir.File("out.bin");
  std::string output;
  EXPECT_EQ(WriteTableWithSizeLimit(out, 1024, &output), 1) << output;
  EXPECT_NE(output.find("error: "), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(out)) << fs::file_size(out) << " bytes left";
  // An existing table stays whole.
  ASSERT_EQ(test::Run(Firmware() + " --write-table " + out).status, 0);
  const std::string whole = FileBytes(out);
  ASSERT_EQ(whole.size(), kTableSize);
  std::ofstream(out, std::ios::binary | std::ios::trunc) << "old content";
  EXPECT_EQ(WriteTableWithSizeLimit(out, 1024, &output), 1) << output;
  EXPECT_EQ(FileBytes(out), "old content");
  EXPECT_EQ(Entries(dir.File("")), std::set<std::string>{"out.bin"});
  // Without a limit it works.
  EXPECT_EQ(WriteTableWithSizeLimit(out, RLIM_INFINITY, &output), 0) << output;
  EXPECT_EQ(FileBytes(out), whole);
}

TEST(TableWriteConformance, AFullDeviceIsAnError) {
  if (access("/dev/full", W_OK) != 0) GTEST_SKIP() << "no /dev/full";
  const CommandResult r = test::Run(Firmware() + " --write-table /dev/full");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("error: "), std::string::npos) << r.output;
}

}  // namespace
}  // namespace mrd::test
