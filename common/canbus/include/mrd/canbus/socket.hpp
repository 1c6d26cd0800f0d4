#pragma once
// Opening a file descriptor that carries `struct can_frame` — the only code that differs
// between a board and a build machine:
//   OpenSocketCan     a CAN_RAW socket bound to an interface (e.g. "can0"), receive filters
//                     and bus-off error frames enabled; needs AF_CAN (a board, or vcan)
//   OpenLocalBusNode  a node on the local frame bus (local_bus.hpp): a UNIX SOCK_SEQPACKET
//                     connection to the relay, one packet per frame
// Both return a non-blocking, close-on-exec fd, or -errno. Neither allocates, so a device may
// reopen from its real-time path (rate-limited). On failure *error (when not null) says why.

#include <linux/can.h>

#include <cstddef>
#include <string>

namespace mrd::canbus {

int OpenSocketCan(const char* interface, const can_filter* filters, std::size_t num_filters,
                  std::string* error);
int OpenLocalBusNode(const char* socket_path, std::string* error);

// True when path names a local frame bus socket (contains '/'), false for an interface name.
bool IsLocalBusPath(const std::string& endpoint);

}  // namespace mrd::canbus
