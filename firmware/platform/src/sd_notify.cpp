#include "mrd/firmware/platform/sd_notify.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstddef>
#include <cstdlib>
#include <cstring>

namespace mrd::firmware::platform {

SystemdNotifier::SystemdNotifier() {
  const char* socket_path = std::getenv("NOTIFY_SOCKET");
  if (socket_path == nullptr) return;
  const std::size_t n = std::strlen(socket_path);
  if (n < 2 || n >= sizeof path_ || (socket_path[0] != '/' && socket_path[0] != '@')) return;
  std::memcpy(path_, socket_path, n);
  if (path_[0] == '@') path_[0] = '\0';  // abstract namespace
  path_length_ = static_cast<unsigned>(n);
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  const char* usec = std::getenv("WATCHDOG_USEC");
  if (usec != nullptr) {
    char* end = nullptr;
    const long long us = std::strtoll(usec, &end, 10);
    if (end != usec && *end == '\0' && us > 0) interval_ns_ = us * 1000 / 2;
  }
}

SystemdNotifier::~SystemdNotifier() {
  if (fd_ >= 0) ::close(fd_);
}

bool SystemdNotifier::Send(const char* message) const {
  if (fd_ < 0) return false;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path_, path_length_);
  const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + path_length_);
  const std::size_t size = std::strlen(message);
  return ::sendto(fd_, message, size, MSG_DONTWAIT | MSG_NOSIGNAL,
                  reinterpret_cast<const sockaddr*>(&addr), len) == static_cast<ssize_t>(size);
}

void SystemdNotifier::Ping(std::int64_t now_ns, std::uint64_t ticks) {
  if (interval_ns_ <= 0 || now_ns - last_ping_ns_ < interval_ns_ || ticks == last_ticks_) return;
  if (Send("WATCHDOG=1")) {
    last_ping_ns_ = now_ns;
    last_ticks_ = ticks;
  }
}

}  // namespace mrd::firmware::platform
