#include "mrd/common/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace mrd {
namespace {

const char* Kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  return "not a regular file";
}

}  // namespace

InputFile OpenInputFile(const char* path, std::uint64_t max_bytes) {
  InputFile f;
  // O_NONBLOCK: opening a FIFO without a writer (or a tty, a device) returns at once.
  const int fd = ::open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) {
    f.error = errno;
    return f;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    f.error = errno;
    ::close(fd);
    return f;
  }
  if (!S_ISREG(st.st_mode)) {
    f.kind = Kind(st.st_mode);
    ::close(fd);
    return f;
  }
  f.size = static_cast<std::uint64_t>(st.st_size);
  if (f.size > max_bytes) {
    f.too_large = true;
    ::close(fd);
    return f;
  }
  // A regular file never blocks; clear O_NONBLOCK anyway so reads behave as usual.
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  f.fd = fd;
  return f;
}

std::string InputFileRefusal(const InputFile& f, std::uint64_t max_bytes) {
  if (f.error != 0) return std::strerror(f.error);
  if (f.too_large) {
    return "is " + std::to_string(f.size) + " bytes, larger than the limit of " +
           std::to_string(max_bytes) + " bytes";
  }
  if (*f.kind != '\0') return std::string("is ") + f.kind + ", not a regular file";
  return "cannot be read";
}

bool ReadInputFileOrWhy(const std::string& path, std::uint64_t max_bytes, std::string* text,
                        std::string* reason) {
  const InputFile f = OpenInputFile(path.c_str(), max_bytes);
  if (f.fd < 0) {
    *reason = InputFileRefusal(f, max_bytes);
    return false;
  }
  std::string out;
  out.resize(static_cast<std::size_t>(f.size) + 1);  // one more byte detects growth
  std::size_t n = 0;
  while (true) {
    if (n == out.size()) {
      if (n > max_bytes) break;
      out.resize(n + 4096 < max_bytes + 1 ? n + 4096 : static_cast<std::size_t>(max_bytes) + 1);
    }
    const ssize_t r = ::read(f.fd, out.data() + n, out.size() - n);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      *reason = std::strerror(errno);
      ::close(f.fd);
      return false;
    }
    if (r == 0) break;
    n += static_cast<std::size_t>(r);
  }
  ::close(f.fd);
  if (n > max_bytes) {
    *reason = "grew past the limit of " + std::to_string(max_bytes) + " bytes while being read";
    return false;
  }
  out.resize(n);
  *text = std::move(out);
  return true;
}

bool ReadInputFile(const std::string& path, std::uint64_t max_bytes, std::string* text,
                   std::string* error) {
  std::string reason;
  if (ReadInputFileOrWhy(path, max_bytes, text, &reason)) return true;
  *error = Printable(path) + ": " + reason;
  return false;
}

std::string Printable(std::string_view text, std::size_t max_chars) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (out.size() >= max_chars) {
      out += "... (" + std::to_string(text.size() - i) + " more bytes)";
      break;
    }
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c >= 0x7f) {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out;
}

}  // namespace mrd
