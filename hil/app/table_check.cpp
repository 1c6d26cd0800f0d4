#include "table_check.hpp"

#include <cstdio>

#include "mrd/common/input_file.hpp"
#include "mrd/firmware/table_file.hpp"

namespace mrd::hil {

bool TableIsUsable(const std::string& path) {
  if (path.empty()) return true;
  std::string reason;
  if (firmware::LoadTableFile(path.c_str(), &reason).ok()) return true;
  std::fprintf(stderr, "error: %s: %s\n", Printable(path).c_str(), reason.c_str());
  return false;
}

}  // namespace mrd::hil
