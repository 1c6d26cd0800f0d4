#include "mrd/canbus/socket.hpp"

#include <fcntl.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace mrd::canbus {
namespace {

int Fail(int fd, int err, const char* what, const char* name, std::string* error) {
  if (fd >= 0) close(fd);
  if (error != nullptr) {
    *error = std::string("can: ") + what + " " + name + ": " + std::strerror(err);
  }
  return -err;
}

}  // namespace

int OpenSocketCan(const char* interface, const can_filter* filters, std::size_t num_filters,
                  std::string* error) {
  if (std::strlen(interface) == 0 || std::strlen(interface) >= IFNAMSIZ) {
    return Fail(-1, EINVAL, "bad interface name", interface, error);
  }
  const int fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return Fail(-1, errno, "cannot create a CAN_RAW socket for", interface, error);
  if (num_filters > 0 &&
      setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters,
                 static_cast<socklen_t>(num_filters * sizeof(can_filter))) != 0) {
    return Fail(fd, errno, "cannot set receive filters on", interface, error);
  }
  const can_err_mask_t err_mask = CAN_ERR_BUSOFF | CAN_ERR_CRTL | CAN_ERR_RESTARTED;
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) != 0) {
    return Fail(fd, errno, "cannot enable error frames on", interface, error);
  }
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, interface, IFNAMSIZ - 1);
  if (ioctl(fd, SIOCGIFINDEX, &ifr) != 0) return Fail(fd, errno, "no interface", interface, error);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  if (bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    return Fail(fd, errno, "cannot bind to", interface, error);
  }
  return fd;
}

int OpenLocalBusNode(const char* socket_path, std::string* error) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (std::strlen(socket_path) == 0 || std::strlen(socket_path) >= sizeof addr.sun_path) {
    return Fail(-1, ENAMETOOLONG, "bad local bus path", socket_path, error);
  }
  std::strncpy(addr.sun_path, socket_path, sizeof addr.sun_path - 1);
  const int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return Fail(-1, errno, "cannot create a socket for local bus", socket_path, error);
  if (connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    return Fail(fd, errno, "cannot connect to local bus", socket_path, error);
  }
  return fd;
}

bool IsLocalBusPath(const std::string& endpoint) { return endpoint.find('/') != std::string::npos; }

}  // namespace mrd::canbus
