#include "mrd/firmware/table_update.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "mrd/common/table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/table_file.hpp"

namespace mrd::firmware {
namespace {

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

bool WriteAll(int fd, const std::uint8_t* data, std::size_t size) {
  std::size_t n = 0;
  while (n < size) {
    const ssize_t w = ::write(fd, data + n, size - n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    n += static_cast<std::size_t>(w);
  }
  return true;
}

// fsync of the folder holding path, so renames in it are durable.
bool SyncFolder(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  const std::string folder = slash == std::string::npos ? "." : path.substr(0, slash + 1);
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  return ok;
}

}  // namespace

std::string CheckTable(const char* path, const FirmwareConfig& config) {
  const auto loaded = LoadTableFile(path);
  if (!loaded.ok()) {
    if (loaded.error() == Error::kIo) return Errno(std::string("cannot read ") + path);
    return std::string("table ") + path + " refused: " + ErrorName(loaded.error());
  }
  ControllerConfig c = config.controller;
  c.e_max = config.e_max.value_or(loaded.value().e_max);
  Controller controller;
  const Error e = controller.Configure(loaded.value(), c);
  if (e != Error::kOk) {
    return std::string("table ") + path + " refused by this firmware and config: " + ErrorName(e);
  }
  return "";
}

std::string InstallTable(const char* source, const char* dest, const FirmwareConfig& config) {
  std::string why = CheckTable(source, config);
  if (!why.empty()) return why;
  const auto table = LoadTableFile(source);
  const auto image = EncodeTable(table.value());
  if (!image.ok()) return std::string("table ") + source + " refused: " + ErrorName(image.error());
  const std::string d = dest;
  const std::string staged = d + ".new";
  const int fd = ::open(staged.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Errno("cannot create " + staged);
  const bool written = WriteAll(fd, image.value().data(), image.value().size()) && ::fsync(fd) == 0;
  const int saved_errno = errno;
  ::close(fd);
  if (!written) {
    ::unlink(staged.c_str());
    errno = saved_errno;
    return Errno("cannot write " + staged);
  }
  why = CheckTable(staged.c_str(), config);  // what is on disk, CRC included
  if (!why.empty()) {
    ::unlink(staged.c_str());
    return why;
  }
  if (::access(dest, F_OK) == 0) {
    const std::string prev = d + ".prev";
    const std::string prev_staged = prev + ".new";
    ::unlink(prev_staged.c_str());
    if (::link(dest, prev_staged.c_str()) != 0 ||
        ::rename(prev_staged.c_str(), prev.c_str()) != 0) {
      why = Errno("cannot keep the previous table as " + prev);
      ::unlink(staged.c_str());
      return why;
    }
  }
  if (::rename(staged.c_str(), dest) != 0) {
    why = Errno("cannot rename " + staged + " onto " + d);
    ::unlink(staged.c_str());
    return why;
  }
  if (!SyncFolder(d)) return Errno("installed " + d + " but cannot fsync its folder");
  return "";
}

std::string CheckTableOrRollBack(const char* dest, const FirmwareConfig& config,
                                 bool* rolled_back) {
  *rolled_back = false;
  const std::string refused = CheckTable(dest, config);
  if (refused.empty()) return "";
  const std::string d = dest;
  const std::string prev = d + ".prev";
  if (::access(prev.c_str(), F_OK) != 0) return refused + "; no previous table " + prev;
  const std::string prev_refused = CheckTable(prev.c_str(), config);
  if (!prev_refused.empty()) return refused + "; previous table also refused: " + prev_refused;
  const std::string kept = d + ".refused";
  ::unlink(kept.c_str());
  if (::access(dest, F_OK) == 0 && ::link(dest, kept.c_str()) != 0) {
    return refused + "; " + Errno("cannot keep it as " + kept);
  }
  if (::rename(prev.c_str(), dest) != 0)
    return refused + "; " + Errno("cannot roll back to " + prev);
  if (!SyncFolder(d)) return Errno("rolled back " + d + " but cannot fsync its folder");
  *rolled_back = true;
  return "";
}

}  // namespace mrd::firmware
