// file_path.hpp: folder and name of a path, a path resolved beside another file.
#include "mrd/common/file_path.hpp"

namespace mrd {

std::string FolderOf(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

std::string BaseNameOf(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string ResolveBeside(const std::string& file, const std::string& path) {
  if (!path.empty() && path[0] == '/') return path;
  const std::size_t slash = file.rfind('/');
  return (slash == std::string::npos ? std::string(".") : file.substr(0, slash)) + "/" + path;
}

}  // namespace mrd
