#pragma once
// Output directories written as a whole (`mrd report`, `mrd compare`, `mrd resid`): files are
// built in a temporary directory beside DIR (".DIR.<what>-XXXXXX"), or inside DIR when DIR's
// parent is not writable; Commit renames that directory to DIR when DIR is absent or empty,
// otherwise moves each file into DIR (each rename atomic, other files in DIR left alone).
// Without Commit (an exception, a terminating signal) the temporary directory is removed.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mrd/host/atomic_write.hpp"

namespace mrd::host {

// Checks an --out directory before anything is computed: not empty, not an existing
// non-directory, parent exists. Throws InputError ("--out DIR: reason").
void CheckOutDir(const std::string& out_dir);

class StagingDir {
 public:
  // what: part of the temporary directory's name (e.g. "report").
  StagingDir(const std::string& out_dir, const std::string& what);
  StagingDir(const StagingDir&) = delete;
  StagingDir& operator=(const StagingDir&) = delete;

  // Path of a file inside the staging directory.
  std::string File(const std::string& name) const;
  // Moves the named files (all files written) into the output directory.
  void Commit(const std::vector<std::string>& names);

 private:
  std::filesystem::path out_;
  std::filesystem::path path_;
  bool inside_ = false;  // staged inside the output directory
  std::unique_ptr<TempDir> dir_;
};

}  // namespace mrd::host
