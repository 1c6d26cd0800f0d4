// write_atomically.hpp: mkstemp beside the target, write, fchmod, fsync, rename.
#include "mrd/common/write_atomically.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace mrd {

bool WriteAtomically(const std::string& path, const std::string& text, std::string* error) {
  std::string temp = path + ".XXXXXX";
  const int fd = mkstemp(temp.data());
  if (fd < 0) {
    *error = path + ": cannot write: " + std::strerror(errno);
    return false;
  }
  std::size_t done = 0;
  int why = 0;
  while (done < text.size()) {
    const ssize_t n = write(fd, text.data() + done, text.size() - done);
    if (n <= 0) {
      why = n < 0 ? errno : ENOSPC;
      break;
    }
    done += static_cast<std::size_t>(n);
  }
  if (why == 0 && (fchmod(fd, 0644) != 0 || fsync(fd) != 0)) why = errno;
  if (close(fd) != 0 && why == 0) why = errno;
  if (why == 0 && std::rename(temp.c_str(), path.c_str()) != 0) why = errno;
  if (why != 0) {
    unlink(temp.c_str());
    *error = path + ": cannot write: " + std::strerror(why);
    return false;
  }
  return true;
}

}  // namespace mrd
