// write_atomically.hpp: mkstemp beside the target, write, fchmod, fsync, rename.
#include "write_atomically.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>

namespace mrd::hil {

bool WriteAtomically(const std::string& path, const std::string& text, std::string* error) {
  std::string temp = path + ".XXXXXX";
  const int fd = mkstemp(temp.data());
  if (fd < 0) {
    *error = path + ": cannot create a temporary file";
    return false;
  }
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = write(fd, text.data() + done, text.size() - done);
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  const bool ok = done == text.size() && fchmod(fd, 0644) == 0 && fsync(fd) == 0;
  if (close(fd) != 0 || !ok || std::rename(temp.c_str(), path.c_str()) != 0) {
    unlink(temp.c_str());
    *error = path + ": cannot write";
    return false;
  }
  return true;
}

}  // namespace mrd::hil
