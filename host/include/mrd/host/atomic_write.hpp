#pragma once
// Every file the CLI writes goes through here: the common atomic writer
// (mrd/common/write_atomically.hpp: a unique temporary .NAME.tmp-XXXXXX in the destination's
// directory, never following a symlink, written, fsync'ed, renamed over the destination, the
// directory fsync'ed) with the host's checks, exceptions and signal cleanup on top. A destination
// that exists and is not a regular file (symlink, device, FIFO, directory) is refused. Temporaries
// and staging directories are registered so that a terminating signal (SIGINT, SIGTERM, SIGHUP,
// SIGQUIT, SIGPIPE) removes them (InstallCleanupHandlers).

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mrd/common/write_atomically.hpp"

namespace mrd::host {

// Throws InputError when path is empty, names something other than a regular file, or its
// directory does not exist or is not writable. Commands call it before their work.
void CheckOutputPath(const std::string& path);

// One output file: the temporary exists from construction until Commit or destruction.
class AtomicFile {
 public:
  // Throws InputError (bad destination) or std::runtime_error (system error text).
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void Write(std::string_view bytes);
  // Flushes to disk (fsync) and closes the temporary; the destination is still untouched.
  void Finish();
  // Renames the finished temporary over the destination.
  void Commit();
  const std::string& path() const { return path_; }

 private:
  void Discard();
  std::string path_;
  mrd::AtomicWriter file_;
  int slot_ = -1;
};

// Writes text to path through an AtomicFile. Throws InputError / std::runtime_error.
void WriteFileAtomic(const std::string& path, std::string_view text);

// Several outputs, all or none: every temporary is written and synced before the first rename;
// should a later rename fail, the outputs already renamed are removed again.
// files: (path, contents).
void WriteFilesAtomic(const std::vector<std::pair<std::string, std::string>>& files);

// A private directory (mkdtemp) holding files only, removed with its files on destruction or
// on a terminating signal unless Release()d. parent: directory to create it in; stem: name
// prefix. Throws std::runtime_error with the system error text.
class TempDir {
 public:
  TempDir(const std::string& parent, const std::string& stem);
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  // Stops removing it (it was renamed into place).
  void Release();

 private:
  std::string path_;
  int slot_ = -1;
};

// Installs the signal handlers that remove registered temporaries, then re-raise the signal
// with its default action (so the exit status still says which signal ended the program).
void InstallCleanupHandlers();

}  // namespace mrd::host
