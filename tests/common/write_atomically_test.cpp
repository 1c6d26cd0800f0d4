// The one atomic writer (mrd/common/write_atomically.hpp): whole or nothing, no temporary
// left behind, the old file intact on failure, errors that name the path.
#include "mrd/common/write_atomically.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>

#include "mrd/common/file_path.hpp"

namespace mrd {
namespace {

namespace fs = std::filesystem;

class Folder {
 public:
  Folder() {
    std::string tmpl = (fs::temp_directory_path() / "mrd-atomic-XXXXXX").string();
    if (mkdtemp(tmpl.data()) != nullptr) path_ = tmpl;
  }
  ~Folder() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string File(const std::string& name) const { return path_ + "/" + name; }
  std::set<std::string> Entries() const {
    std::set<std::string> out;
    for (const auto& e : fs::directory_iterator(path_)) out.insert(e.path().filename().string());
    return out;
  }

 private:
  std::string path_;
};

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void Put(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(WriteAtomicallyTest, WritesAndReplacesAFileLeavingNoTemporary) {
  Folder dir;
  const std::string out = dir.File("out.txt");
  std::string error;
  ASSERT_TRUE(WriteAtomically(out, "first\n", &error)) << error;
  EXPECT_EQ(Slurp(out), "first\n");
  EXPECT_EQ(dir.Entries(), std::set<std::string>{"out.txt"});
  ASSERT_TRUE(WriteAtomically(out, std::string(100000, 'x'), &error)) << error;
  EXPECT_EQ(Slurp(out), std::string(100000, 'x'));
  ASSERT_TRUE(WriteAtomically(out, "", &error)) << error;
  EXPECT_EQ(Slurp(out), "");
  EXPECT_EQ(dir.Entries(), std::set<std::string>{"out.txt"});
}

TEST(WriteAtomicallyTest, NewFilesGetTheUmaskModeAndKeepModeKeepsTheOldOne) {
  Folder dir;
  const mode_t old_mask = umask(022);
  std::string error;
  ASSERT_TRUE(WriteAtomically(dir.File("plain"), "x", &error)) << error;
  Put(dir.File("private"), "secret = 1\n");
  ASSERT_EQ(chmod(dir.File("private").c_str(), 0600), 0);
  AtomicWriter w;
  ASSERT_TRUE(w.Open(dir.File("private"), {.keep_mode = true}) && w.Write("secret = 2\n") &&
              w.Commit())
      << w.Error();
  umask(old_mask);
  struct stat st {};
  ASSERT_EQ(stat(dir.File("plain").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0644u);
  ASSERT_EQ(stat(dir.File("private").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(Slurp(dir.File("private")), "secret = 2\n");
}

TEST(WriteAtomicallyTest, TargetThatIsAFolderStaysAndTheErrorNamesThePath) {
  Folder dir;
  const std::string target = dir.File("sub");
  fs::create_directory(target);
  Put(target + "/inside", "kept");
  std::string error;
  EXPECT_FALSE(WriteAtomically(target, "x", &error));
  EXPECT_EQ(error, target + ": cannot write: " + std::strerror(EISDIR));
  EXPECT_EQ(Slurp(target + "/inside"), "kept");
  EXPECT_EQ(dir.Entries(), std::set<std::string>{"sub"});
}

TEST(WriteAtomicallyTest, MissingFolderFailsWithThePathAndTheSystemText) {
  Folder dir;
  const std::string target = dir.File("nodir/out");
  std::string error;
  EXPECT_FALSE(WriteAtomically(target, "x", &error));
  EXPECT_EQ(error, target + ": cannot write: No such file or directory");
  AtomicWriter w;
  EXPECT_FALSE(w.Open(target));
  EXPECT_EQ(w.failed_step(), AtomicWriter::Step::kCreate);
  EXPECT_EQ(w.Error(),
            "cannot create a temporary file beside " + target + ": No such file or directory");
  EXPECT_TRUE(dir.Entries().empty());
}

// A write that fails half way (the file size limit: EFBIG) leaves the old file as it was.
TEST(WriteAtomicallyTest, FailedWriteLeavesTheOldFileAndNoTemporary) {
  Folder dir;
  const std::string out = dir.File("table.bin");
  Put(out, "old contents\n");
  rlimit before{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &before), 0);
  rlimit small = before;
  small.rlim_cur = 4096;
  struct sigaction ignore {
  }, old_action{};
  ignore.sa_handler = SIG_IGN;
  sigaction(SIGXFSZ, &ignore, &old_action);
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string error;
  const bool ok = WriteAtomically(out, std::string(10000, 'n'), &error);
  AtomicWriter w;
  const bool stepwise = w.Open(out) && w.Write(std::string(10000, 'n'));
  setrlimit(RLIMIT_FSIZE, &before);
  sigaction(SIGXFSZ, &old_action, nullptr);
  EXPECT_FALSE(ok);
  EXPECT_EQ(error, out + ": cannot write: " + std::strerror(EFBIG));
  EXPECT_FALSE(stepwise);
  EXPECT_EQ(w.failed_step(), AtomicWriter::Step::kWrite);
  EXPECT_EQ(w.Error(), "cannot write " + w.temp() + ": " + std::strerror(EFBIG));
  EXPECT_EQ(w.temp().rfind(out + kAtomicTempInfix, 0), 0u) << w.temp();
  EXPECT_EQ(Slurp(out), "old contents\n");
  EXPECT_EQ(dir.Entries(), std::set<std::string>{"table.bin"});
}

// The target is never followed: a symlink there is replaced by the new file, its target kept.
TEST(WriteAtomicallyTest, SymlinkAtTheTargetIsReplacedNotWrittenThrough) {
  Folder dir;
  Put(dir.File("victim"), "precious");
  ASSERT_EQ(symlink(dir.File("victim").c_str(), dir.File("link").c_str()), 0);
  std::string error;
  ASSERT_TRUE(WriteAtomically(dir.File("link"), "new", &error)) << error;
  EXPECT_FALSE(fs::is_symlink(dir.File("link")));
  EXPECT_EQ(Slurp(dir.File("link")), "new");
  EXPECT_EQ(Slurp(dir.File("victim")), "precious");
}

TEST(WriteAtomicallyTest, FinishedTemporaryIsHiddenUntilCommitAndRemovedByDiscard) {
  Folder dir;
  const std::string out = dir.File("out.csv");
  Put(out, "old");
  {
    AtomicWriter w;
    ASSERT_TRUE(w.Open(out, {.hidden_temp = true}));
    ASSERT_TRUE(w.Write("new") && w.Finish()) << w.Error();
    EXPECT_EQ(BaseNameOf(w.temp()).rfind(".out.csv.tmp-", 0), 0u) << w.temp();
    EXPECT_EQ(Slurp(w.temp()), "new");
    EXPECT_EQ(Slurp(out), "old");
    EXPECT_EQ(dir.Entries().size(), 2u);
  }  // destroyed uncommitted
  EXPECT_EQ(dir.Entries(), std::set<std::string>{"out.csv"});
  EXPECT_EQ(Slurp(out), "old");
  AtomicWriter w;
  ASSERT_TRUE(w.Open(out) && w.Write("new") && w.Finish() && w.Commit()) << w.Error();
  EXPECT_TRUE(w.committed());
  EXPECT_EQ(Slurp(out), "new");
  EXPECT_EQ(dir.Entries(), std::set<std::string>{"out.csv"});
}

TEST(FilePathTest, FolderNameAndResolveBeside) {
  EXPECT_EQ(FolderOf("a/b/c.toml"), "a/b");
  EXPECT_EQ(FolderOf("c.toml"), ".");
  EXPECT_EQ(FolderOf("/c.toml"), "/");
  EXPECT_EQ(BaseNameOf("a/b/c.toml"), "c.toml");
  EXPECT_EQ(BaseNameOf("c.toml"), "c.toml");
  EXPECT_EQ(ResolveBeside("cfg/fw.toml", "table.bin"), "cfg/table.bin");
  EXPECT_EQ(ResolveBeside("cfg/fw.toml", "/abs/table.bin"), "/abs/table.bin");
  EXPECT_EQ(ResolveBeside("fw.toml", "table.bin"), "./table.bin");
  EXPECT_EQ(ResolveBeside("/fw.toml", "table.bin"), "/table.bin");
  EXPECT_EQ(ResolveBeside("cfg/fw.toml", ""), "cfg/");
}

}  // namespace
}  // namespace mrd
