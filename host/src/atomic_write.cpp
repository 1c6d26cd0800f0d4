#include "mrd/host/atomic_write.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <stdexcept>

#include "mrd/common/file_path.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host {
namespace {

// Registry of paths to remove on a signal: fixed storage, read by the handler without locks.
constexpr std::size_t kSlots = 64;
constexpr std::size_t kPathMax = 4096;
enum SlotState : int { kFree = 0, kBusy = 1, kFile = 2, kDir = 3 };
struct Slot {
  std::atomic<int> state{kFree};
  std::array<char, kPathMax> path{};
};
std::array<Slot, kSlots> g_slots;

int Register(const std::string& path, SlotState kind) {
  if (path.size() >= kPathMax) return -1;
  for (std::size_t i = 0; i < kSlots; ++i) {
    int expected = kFree;
    if (g_slots[i].state.compare_exchange_strong(expected, kBusy)) {
      std::memcpy(g_slots[i].path.data(), path.c_str(), path.size() + 1);
      g_slots[i].state.store(kind);
      return static_cast<int>(i);
    }
  }
  return -1;  // full: the temporary is still removed on every normal path
}

void Unregister(int slot) {
  if (slot >= 0) g_slots[static_cast<std::size_t>(slot)].state.store(kFree);
}

// Async-signal-safe removal of a flat directory: open, getdents64, unlinkat, rmdir.
void RemoveFlatDir(const char* path) {
  const int fd = open(path, O_RDONLY | O_DIRECTORY | O_NOFOLLOW);
  if (fd >= 0) {
    alignas(8) char buf[4096];
    while (true) {
      const long n = syscall(SYS_getdents64, fd, buf, sizeof buf);
      if (n <= 0) break;
      for (long off = 0; off < n;) {
        const char* rec = buf + off;
        unsigned short reclen = 0;
        std::memcpy(&reclen, rec + 16, sizeof reclen);
        const char* name = rec + 19;
        if (std::strcmp(name, ".") != 0 && std::strcmp(name, "..") != 0) unlinkat(fd, name, 0);
        off += reclen;
      }
    }
    close(fd);
  }
  rmdir(path);
}

void CleanupHandler(int sig) {
  for (auto& s : g_slots) {
    const int st = s.state.load();
    if (st == kFile) unlink(s.path.data());
    if (st == kDir) RemoveFlatDir(s.path.data());
  }
  signal(sig, SIG_DFL);
  raise(sig);
}

std::string SysError(const std::string& what, const std::string& path) {
  return fmt::format("{}: {}: {}", path, what, std::strerror(errno));
}

// Throws std::runtime_error "PATH: WHAT: REASON" with the failed step's errno text.
[[noreturn]] void ThrowSysError(const mrd::AtomicWriter& file, const char* what) {
  errno = file.error_number();
  throw std::runtime_error(SysError(what, file.path()));
}

}  // namespace

void CheckOutputPath(const std::string& path) {
  if (path.empty()) throw InputError("", 0, "output file name is empty");
  if (path.back() == '/') throw InputError(path, 0, "output names a directory");
  struct stat st {};
  if (lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    throw InputError(path, 0,
                     S_ISLNK(st.st_mode)
                         ? "output exists and is a symbolic link; refusing to write through it"
                         : "output exists and is not a regular file; refusing to replace it");
  }
  // The temporary is created beside the output: its directory must exist and be writable.
  const std::string dir = FolderOf(path);
  if (access(dir.c_str(), W_OK | X_OK) != 0) {
    throw InputError(path, 0,
                     fmt::format("cannot write into directory {}: {}", dir, std::strerror(errno)));
  }
}

AtomicFile::AtomicFile(const std::string& path) : path_(path) {
  CheckOutputPath(path);
  if (!file_.Open(path, {.hidden_temp = true})) {
    ThrowSysError(file_, "cannot create a temporary file");
  }
  slot_ = Register(file_.temp(), kFile);
}

AtomicFile::~AtomicFile() { Discard(); }

void AtomicFile::Discard() {
  file_.Discard();
  Unregister(slot_);
  slot_ = -1;
}

void AtomicFile::Write(std::string_view bytes) {
  if (file_.Write(bytes)) return;
  Discard();
  ThrowSysError(file_, "write failed");
}

void AtomicFile::Finish() {
  if (file_.Finish()) return;
  Discard();
  ThrowSysError(file_, "cannot write");
}

void AtomicFile::Commit() {
  Finish();
  CheckOutputPath(path_);  // may have changed while we wrote
  const bool ok = file_.Commit();
  Discard();  // the temporary is gone either way (renamed or removed)
  if (!ok) {
    ThrowSysError(file_, file_.committed() ? "written but cannot fsync its folder"
                                           : "cannot rename the temporary file into place");
  }
}

void WriteFileAtomic(const std::string& path, std::string_view text) {
  AtomicFile f(path);
  f.Write(text);
  f.Commit();
}

void WriteFilesAtomic(const std::vector<std::pair<std::string, std::string>>& files) {
  std::vector<std::unique_ptr<AtomicFile>> open;
  for (const auto& [path, text] : files) {
    open.push_back(std::make_unique<AtomicFile>(path));
    open.back()->Write(text);
    open.back()->Finish();
  }
  for (std::size_t i = 0; i < open.size(); ++i) {
    try {
      open[i]->Commit();
    } catch (...) {
      for (std::size_t j = 0; j < i; ++j) unlink(open[j]->path().c_str());
      throw;
    }
  }
}

TempDir::TempDir(const std::string& parent, const std::string& stem) {
  std::string tmpl = parent + "/" + stem + "-XXXXXX";
  if (mkdtemp(tmpl.data()) == nullptr) {
    throw std::runtime_error(SysError("cannot create a temporary directory", parent));
  }
  path_ = tmpl;
  slot_ = Register(path_, kDir);
}

TempDir::~TempDir() {
  if (!path_.empty()) RemoveFlatDir(path_.c_str());
  Unregister(slot_);
}

void TempDir::Release() {
  Unregister(slot_);
  slot_ = -1;
  path_.clear();
}

void InstallCleanupHandlers() {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE}) {
    struct sigaction sa {};
    sa.sa_handler = CleanupHandler;
    sigemptyset(&sa.sa_mask);
    sigaction(sig, &sa, nullptr);
  }
}

}  // namespace mrd::host
