#include "file_text.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace mrd::profile {

bool ReadTextFile(const std::string& path, std::size_t max_bytes, std::string* text,
                  std::string* error) {
  const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    *error = path + ": cannot open (" + std::strerror(errno) + ")";
    return false;
  }
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(fd);
    *error = path + ": not a regular file";
    return false;
  }
  if (static_cast<std::size_t>(st.st_size) > max_bytes) {
    close(fd);
    *error = path + ": larger than " + std::to_string(max_bytes) + " bytes";
    return false;
  }
  text->assign(static_cast<std::size_t>(st.st_size), '\0');
  std::size_t got = 0;
  while (got < text->size()) {
    const ssize_t n = read(fd, text->data() + got, text->size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  close(fd);
  text->resize(got);
  return true;
}

}  // namespace mrd::profile
