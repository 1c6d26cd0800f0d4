#pragma once
// The one atomic file writer of every program (host, harness, firmware platform): a file is
// written whole or not at all, and a written file survives a power cut.
//   1. a unique temporary beside the target (mkostemp: O_CREAT | O_EXCL, so a symlink or file
//      planted at that name is never opened): PATH.tmp-XXXXXX, or DIR/.NAME.tmp-XXXXXX;
//   2. every byte written (short writes continued, EINTR retried), permissions set, fsync,
//      close;
//   3. renamed over the target, then the target's folder fsync'ed (the rename is durable).
// Symlinks: the target is never followed. A symlink at the target is replaced by the new file
// (rename's rule); callers that must not replace one (the host's outputs, table files) refuse
// it before writing. Errors by return value (common/ is linked into the no-exceptions
// firmware); on any failure before the rename the temporary is removed and the target is
// untouched.

#include <string>
#include <string_view>

namespace mrd {

// Temporary names: PATH + kAtomicTempInfix + 6 characters (mkostemp's XXXXXX).
inline constexpr const char* kAtomicTempInfix = ".tmp-";

struct AtomicWriteOptions {
  bool hidden_temp = false;  // DIR/.NAME.tmp-XXXXXX instead of PATH.tmp-XXXXXX
  bool keep_mode = false;    // permission bits of the existing target; else 0666 & ~umask
};

class AtomicWriter {
 public:
  // The step that failed (error_number() holds its errno).
  enum class Step { kNone, kCreate, kWrite, kRename, kSyncFolder };

  AtomicWriter() = default;
  ~AtomicWriter() { Discard(); }
  AtomicWriter(const AtomicWriter&) = delete;
  AtomicWriter& operator=(const AtomicWriter&) = delete;

  // Creates the temporary beside path. False (kCreate) when it cannot.
  bool Open(const std::string& path, AtomicWriteOptions options = {});
  // Appends bytes to the temporary. False (kWrite; temporary removed) on a write error.
  bool Write(std::string_view bytes);
  // Sets the permissions, fsyncs and closes the temporary; the target is still untouched.
  // False (kWrite; temporary removed) on failure. Idempotent.
  bool Finish();
  // Finish, rename over the target (kRename; temporary removed), fsync the target's folder
  // (kSyncFolder: the new file is in place, committed() is true).
  bool Commit();
  // Closes and removes the temporary unless committed. Idempotent.
  void Discard();

  const std::string& path() const { return path_; }
  // The temporary's name (kept after a failure, for the message).
  const std::string& temp() const { return temp_; }
  bool committed() const { return committed_; }
  Step failed_step() const { return step_; }
  int error_number() const { return errno_; }
  // The failure in words with the paths and strerror text: "cannot create a temporary file
  // beside PATH: R", "cannot write TEMP: R", "cannot rename TEMP onto PATH: R", or
  // "DONE PATH but cannot fsync its folder: R". "" when nothing failed.
  std::string Error(const char* done = "wrote") const;

 private:
  bool Fail(Step step, int error_number);

  std::string path_;
  std::string temp_;
  AtomicWriteOptions options_;
  int fd_ = -1;
  bool temp_exists_ = false;  // created and neither removed nor renamed
  bool committed_ = false;
  Step step_ = Step::kNone;
  int errno_ = 0;
};

// Writes text to path through an AtomicWriter. False with *error = "PATH: cannot write:
// REASON" (strerror), the temporary removed, path untouched (or, when only the folder's fsync
// failed, "PATH: written but cannot fsync its folder: REASON").
bool WriteAtomically(const std::string& path, std::string_view text, std::string* error);

// fsync of the folder holding path, so that a rename in it is durable. False with errno set.
bool SyncFolderOf(const std::string& path);

}  // namespace mrd
