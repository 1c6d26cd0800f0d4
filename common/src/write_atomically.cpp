// write_atomically.hpp: mkostemp beside the target, write, chmod, fsync, rename, fsync folder.
#include "mrd/common/write_atomically.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "mrd/common/file_path.hpp"

namespace mrd {
namespace {

std::string TempTemplate(const std::string& path, bool hidden) {
  if (!hidden) return path + kAtomicTempInfix + "XXXXXX";
  const std::size_t slash = path.rfind('/');
  const std::size_t name = slash == std::string::npos ? 0 : slash + 1;
  return path.substr(0, name) + "." + path.substr(name) + kAtomicTempInfix + "XXXXXX";
}

// The permission bits of a plain create (0666 & ~umask), or of the existing target.
mode_t NewFileMode(const std::string& path, bool keep_mode) {
  struct stat st {};
  if (keep_mode && ::stat(path.c_str(), &st) == 0) return st.st_mode & 07777;
  const mode_t mask = ::umask(0);
  ::umask(mask);
  return 0666 & ~mask;
}

}  // namespace

bool AtomicWriter::Fail(Step step, int error_number) {
  step_ = step;
  errno_ = error_number;
  if (step != Step::kSyncFolder) Discard();
  return false;
}

bool AtomicWriter::Open(const std::string& path, AtomicWriteOptions options) {
  Discard();
  path_ = path;
  temp_.clear();
  options_ = options;
  committed_ = false;
  step_ = Step::kNone;
  errno_ = 0;
  std::string name = TempTemplate(path, options.hidden_temp);
  fd_ = ::mkostemp(name.data(), O_CLOEXEC);
  if (fd_ < 0) return Fail(Step::kCreate, errno);
  temp_ = name;
  temp_exists_ = true;
  return true;
}

bool AtomicWriter::Write(std::string_view bytes) {
  if (fd_ < 0) return Fail(Step::kWrite, EBADF);
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd_, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return Fail(Step::kWrite, n < 0 ? errno : EIO);
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

bool AtomicWriter::Finish() {
  if (fd_ < 0) return temp_exists_ || Fail(Step::kWrite, EBADF);  // finished already
  int why = 0;
  if (::fchmod(fd_, NewFileMode(path_, options_.keep_mode)) != 0 || ::fsync(fd_) != 0) {
    why = errno;
  }
  if (::close(fd_) != 0 && why == 0) why = errno;  // never retried: the fd is gone either way
  fd_ = -1;
  return why == 0 || Fail(Step::kWrite, why);
}

bool AtomicWriter::Commit() {
  if (!Finish()) return false;
  if (std::rename(temp_.c_str(), path_.c_str()) != 0) return Fail(Step::kRename, errno);
  committed_ = true;
  temp_exists_ = false;
  return SyncFolderOf(path_) || Fail(Step::kSyncFolder, errno);
}

void AtomicWriter::Discard() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (temp_exists_) ::unlink(temp_.c_str());
  temp_exists_ = false;
}

std::string AtomicWriter::Error(const char* done) const {
  const std::string why = std::strerror(errno_);
  switch (step_) {
    case Step::kNone:
      return "";
    case Step::kCreate:
      return "cannot create a temporary file beside " + path_ + ": " + why;
    case Step::kWrite:
      return "cannot write " + temp_ + ": " + why;
    case Step::kRename:
      return "cannot rename " + temp_ + " onto " + path_ + ": " + why;
    case Step::kSyncFolder:
      return std::string(done) + " " + path_ + " but cannot fsync its folder: " + why;
  }
  return "";
}

bool WriteAtomically(const std::string& path, std::string_view text, std::string* error) {
  AtomicWriter w;
  if (w.Open(path) && w.Write(text) && w.Commit()) return true;
  const std::string why = std::strerror(w.error_number());
  *error = w.failed_step() == AtomicWriter::Step::kSyncFolder
               ? path + ": written but cannot fsync its folder: " + why
               : path + ": cannot write: " + why;
  return false;
}

bool SyncFolderOf(const std::string& path) {
  const int fd = ::open(FolderOf(path).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  const int saved = errno;
  ::close(fd);
  errno = saved;
  return ok;
}

}  // namespace mrd
