#include "mrd/firmware/table_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>

namespace mrd::firmware {

Result<CoefficientTable> LoadTableFile(const char* path) {
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Error::kIo;
  std::array<std::uint8_t, kTableSize + 1> buf{};  // one more byte detects a longer file
  std::size_t n = 0;
  while (n < buf.size()) {
    const ssize_t r = ::read(fd, buf.data() + n, buf.size() - n);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      ::close(fd);
      return Error::kIo;
    }
    if (r == 0) break;
    n += static_cast<std::size_t>(r);
  }
  ::close(fd);
  return DecodeTable(std::span<const std::uint8_t>(buf.data(), n));
}

}  // namespace mrd::firmware
