#include "mrd/firmware/platform/table_update.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>

#include "mrd/common/file_path.hpp"
#include "mrd/common/table.hpp"
#include "mrd/common/write_atomically.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/platform/table_file.hpp"

namespace mrd::firmware::platform {
namespace {

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

// "" when path is missing or a regular file; else why it must not be replaced (a symlink,
// device, FIFO or folder at the destination is refused, never written through).
std::string NotRegular(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return errno == ENOENT ? "" : Errno("cannot stat " + path);
  if (S_ISREG(st.st_mode)) return "";
  const char* kind = S_ISLNK(st.st_mode)    ? "a symbolic link"
                     : S_ISDIR(st.st_mode)  ? "a directory"
                     : S_ISFIFO(st.st_mode) ? "a FIFO"
                     : S_ISCHR(st.st_mode)  ? "a character device"
                     : S_ISBLK(st.st_mode)  ? "a block device"
                                            : "not a regular file";
  return path + " is " + kind + ", not a regular file: refused";
}

// A new, empty file PATH.tmp-XXXXXX beside path that reserves a unique name (mkostemp:
// O_CREAT | O_EXCL, so a symlink or any file at that name is never opened). -1 on failure
// (errno).
int ReserveTemp(const std::string& path, std::string* name) {
  std::string tmpl = path + kAtomicTempInfix + "XXXXXX";
  const int fd = ::mkostemp(tmpl.data(), O_CLOEXEC);
  if (fd >= 0) *name = tmpl;
  return fd;
}

// Writes image to a new temporary beside path, fsynced and closed (every step checked), in
// *file. "" or the reason (the temporary removed).
std::string WriteTemp(const std::string& path, const TableBytes& image, AtomicWriter* file) {
  if (file->Open(path) &&
      file->Write({reinterpret_cast<const char*>(image.data()), image.size()}) && file->Finish()) {
    return "";
  }
  return file->Error();
}

// Removes temporaries a killed install left beside path (PATH.tmp-XXXXXX and
// PATH.prev.tmp-XXXXXX regular files). Only under the install lock.
void RemoveStaleTemps(const std::string& path) {
  const std::string folder = FolderOf(path);
  DIR* dir = ::opendir(folder.c_str());
  if (dir == nullptr) return;
  const std::string base = BaseNameOf(path);
  const std::string prefixes[] = {base + kAtomicTempInfix, base + ".prev" + kAtomicTempInfix};
  while (const dirent* e = ::readdir(dir)) {
    const std::string name = e->d_name;
    for (const std::string& p : prefixes) {
      if (name.size() != p.size() + 6 || name.compare(0, p.size(), p) != 0) continue;
      struct stat st {};
      const std::string full = folder + "/" + name;
      if (::lstat(full.c_str(), &st) == 0 && S_ISREG(st.st_mode)) ::unlink(full.c_str());
    }
  }
  ::closedir(dir);
}

// flock(LOCK_EX) on DEST.lock (created if missing, never through a symlink): one install or
// rollback of DEST at a time. Waits up to kLockWait for another one to finish.
class DestLock {
 public:
  static constexpr std::chrono::seconds kLockWait{60};

  explicit DestLock(const std::string& dest) : path_(dest + ".lock") {}
  ~DestLock() {
    if (fd_ >= 0) ::close(fd_);  // releases the lock
  }
  DestLock(const DestLock&) = delete;
  DestLock& operator=(const DestLock&) = delete;

  // "" when held, else the reason.
  std::string Acquire() {
    fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd_ < 0) return Errno("cannot open the lock file " + path_);
    const auto until = std::chrono::steady_clock::now() + kLockWait;
    while (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      if (errno != EWOULDBLOCK && errno != EINTR) return Errno("cannot lock " + path_);
      if (std::chrono::steady_clock::now() > until) {
        return path_ + " is held by another install or rollback for more than " +
               std::to_string(kLockWait.count()) + " s";
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return "";
  }

 private:
  std::string path_;
  int fd_ = -1;
};

// Hard-links dest to a fresh PATH.prev.tmp-XXXXXX name, then renames that onto DEST.prev
// (replacing whatever entry DEST.prev was, never writing through it). "" or the reason.
std::string KeepPrevious(const std::string& dest) {
  const std::string prev = dest + ".prev";
  for (int attempt = 0; attempt < 10; ++attempt) {
    std::string name;
    const int fd = ReserveTemp(prev, &name);
    if (fd < 0) return Errno("cannot create a temporary file beside " + prev);
    ::close(fd);
    ::unlink(name.c_str());
    if (::link(dest.c_str(), name.c_str()) != 0) {
      if (errno == EEXIST) continue;  // taken meanwhile: another name
      return Errno("cannot keep the previous table as " + prev);
    }
    if (::rename(name.c_str(), prev.c_str()) != 0) {
      const std::string why = Errno("cannot keep the previous table as " + prev);
      ::unlink(name.c_str());
      return why;
    }
    return "";
  }
  return "cannot keep the previous table as " + prev + ": no free temporary name";
}

// Renames the finished temporary onto its target, then fsyncs the target's folder. "" or the
// reason; `done` says what was done when only the fsync failed.
std::string Commit(AtomicWriter* file, const char* done) {
  return file->Commit() ? "" : file->Error(done);
}

}  // namespace

std::string CheckTable(const char* path, const FirmwareConfig& config) {
  std::string reason;
  const auto loaded = LoadTableFile(path, &reason);
  if (!loaded.ok()) {
    if (loaded.error() == Error::kIo) return std::string("cannot read ") + path + ": " + reason;
    return std::string("table ") + path + " refused: " + reason;
  }
  ControllerConfig c = config.controller;
  c.e_max = config.e_max.value_or(loaded.value().e_max);
  Controller controller;
  const ConfigureStatus e = controller.Configure(loaded.value(), c);
  if (!e.ok()) {
    return std::string("table ") + path + " refused by this firmware and config: " +
           (e.fault == ConfigureFault::kTable ? ErrorName(e.error) : ConfigureFaultName(e.fault));
  }
  return "";
}

std::string WriteTableFile(const char* path, const CoefficientTable& table) {
  const auto image = EncodeTable(table);
  if (!image.ok()) return std::string("table refused: ") + ErrorName(image.error());
  const std::string p = path;
  std::string why = NotRegular(p);
  if (!why.empty()) return why;
  AtomicWriter file;
  why = WriteTemp(p, image.value(), &file);
  if (!why.empty()) return why;
  return Commit(&file, "wrote");
}

std::string InstallTable(const char* source, const char* dest, const FirmwareConfig& config) {
  std::string why = CheckTable(source, config);
  if (!why.empty()) return why;
  const auto table = LoadTableFile(source);
  if (!table.ok()) return std::string("cannot read ") + source;  // changed since the check
  const auto image = EncodeTable(table.value());
  if (!image.ok()) return std::string("table ") + source + " refused: " + ErrorName(image.error());
  const std::string d = dest;
  DestLock lock(d);
  why = lock.Acquire();
  if (!why.empty()) return why;
  why = NotRegular(d);
  if (!why.empty()) return why;
  RemoveStaleTemps(d);
  AtomicWriter staged;  // removed on every early return
  why = WriteTemp(d, image.value(), &staged);
  if (!why.empty()) return why;
  why = CheckTable(staged.temp().c_str(), config);  // what is on disk, CRC included
  if (!why.empty()) return why;
  struct stat st {};
  if (::lstat(dest, &st) == 0) {
    why = KeepPrevious(d);
    if (!why.empty()) return why;
  }
  return Commit(&staged, "installed");
}

std::string CheckTableOrRollBack(const char* dest, const FirmwareConfig& config,
                                 bool* rolled_back) {
  *rolled_back = false;
  if (CheckTable(dest, config).empty()) return "";  // no lock needed (read-only folders too)
  const std::string d = dest;
  DestLock lock(d);
  const std::string locked = lock.Acquire();
  // Checked again under the lock: an install may have replaced DEST meanwhile.
  const std::string refused = CheckTable(dest, config);
  if (refused.empty()) return "";
  if (!locked.empty()) return refused + "; cannot roll back: " + locked;
  const std::string prev = d + ".prev";
  if (::access(prev.c_str(), F_OK) != 0) return refused + "; no previous table " + prev;
  const std::string prev_refused = CheckTable(prev.c_str(), config);
  if (!prev_refused.empty()) return refused + "; previous table also refused: " + prev_refused;
  const std::string kept = d + ".refused";
  ::unlink(kept.c_str());
  if (::access(dest, F_OK) == 0 && ::link(dest, kept.c_str()) != 0) {
    return refused + "; " + Errno("cannot keep it as " + kept);
  }
  if (::rename(prev.c_str(), dest) != 0)
    return refused + "; " + Errno("cannot roll back to " + prev);
  if (!SyncFolderOf(d)) return Errno("rolled back " + d + " but cannot fsync its folder");
  *rolled_back = true;
  return "";
}

}  // namespace mrd::firmware::platform
