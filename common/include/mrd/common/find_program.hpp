#pragma once
// The full path of an executable on PATH, for posix_spawn. Entries this user cannot search are
// skipped. glibc's posix_spawnp is not used because it reports EACCES from an unsearchable
// PATH entry (e.g. /root/... when run as another user) even when a later entry runs the
// program, so a caller would see a failure for a program that ran.

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <string_view>

namespace mrd::common {

// Empty when no PATH entry holds a regular file `name` this user may execute. An empty PATH
// entry means the current directory, as for the shell; an unset PATH means "/usr/bin:/bin".
inline std::string FindProgram(std::string_view name) {
  const char* env = std::getenv("PATH");
  std::string_view rest = env != nullptr ? env : "/usr/bin:/bin";
  while (true) {
    const std::size_t colon = rest.find(':');
    const std::string_view dir = rest.substr(0, colon);
    std::string candidate = dir.empty() ? std::string(".") : std::string(dir);
    candidate.append("/").append(name);
    struct stat st {};
    if (stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
        access(candidate.c_str(), X_OK) == 0)
      return candidate;
    if (colon == std::string_view::npos) return {};
    rest.remove_prefix(colon + 1);
  }
}

}  // namespace mrd::common
