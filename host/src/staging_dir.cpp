#include "mrd/host/staging_dir.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include "mrd/host/input_error.hpp"

namespace mrd::host {

namespace fs = std::filesystem;

namespace {

bool Writable(const fs::path& dir) { return access(dir.c_str(), W_OK | X_OK) == 0; }

// The files are staged beside out (in parent) or inside out: an existing out must be writable
// (or empty, to be replaced by the staged directory), an absent one needs a writable parent.
void CheckWritable(const std::string& out_dir, const fs::path& out, const fs::path& parent) {
  std::error_code ec;
  const bool exists = fs::is_directory(out, ec);
  if (exists && (Writable(out) || (fs::is_empty(out, ec) && Writable(parent)))) return;
  if (!exists && Writable(parent)) return;
  const fs::path& dir = exists ? out : parent;
  access(dir.c_str(), W_OK | X_OK);  // errno of the refusal
  throw InputError("", 0,
                   fmt::format("--out {}: cannot write into {}: {}", out_dir, dir.string(),
                               std::strerror(errno)));
}

}  // namespace

void CheckOutDir(const std::string& out_dir) {
  if (out_dir.empty()) throw InputError("", 0, "--out: empty directory name");
  const fs::path out = fs::absolute(fs::path(out_dir)).lexically_normal();
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec)) {
    throw InputError("", 0, fmt::format("--out {}: exists and is not a directory", out_dir));
  }
  const fs::path parent = out.has_filename() ? out.parent_path() : out.parent_path().parent_path();
  if (!fs::is_directory(parent, ec)) {
    throw InputError(
        "", 0,
        fmt::format("--out {}: parent directory {} does not exist", out_dir, parent.string()));
  }
  CheckWritable(out_dir, out, parent);
}

StagingDir::StagingDir(const std::string& out_dir, const std::string& what) {
  fs::path out = fs::absolute(fs::path(out_dir)).lexically_normal();
  if (!out.has_filename()) out = out.parent_path();
  out_ = out;
  const std::string stem = fmt::format(".{}.{}", out.filename().string(), what);
  try {
    dir_ = std::make_unique<TempDir>(out.parent_path().string(), stem);
  } catch (const std::runtime_error&) {
    std::error_code ec;
    if (!fs::is_directory(out_, ec)) throw;
    inside_ = true;
    dir_ = std::make_unique<TempDir>(out_.string(), fmt::format(".{}", what));
  }
  path_ = dir_->path();
}

std::string StagingDir::File(const std::string& name) const { return (path_ / name).string(); }

void StagingDir::Commit(const std::vector<std::string>& names) {
  std::error_code ec;
  const bool empty_dir = fs::is_directory(out_, ec) && fs::is_empty(out_, ec);
  if (!inside_ && (!fs::exists(out_, ec) || empty_dir)) {
    if (empty_dir) fs::remove(out_, ec);
    fs::permissions(path_,
                    fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                        fs::perms::others_read | fs::perms::others_exec,
                    ec);
    fs::rename(path_, out_, ec);
    if (ec) throw std::runtime_error(fmt::format("{}: {}", out_.string(), ec.message()));
    dir_->Release();
    return;
  }
  for (const std::string& name : names) {
    CheckOutputPath((out_ / name).string());
    fs::rename(path_ / name, out_ / name, ec);
    if (ec) throw std::runtime_error(fmt::format("{}: {}", (out_ / name).string(), ec.message()));
  }
}

}  // namespace mrd::host
