#pragma once
// systemd service notifications (Type=notify, WatchdogSec) without libsystemd: one AF_UNIX
// datagram per message to $NOTIFY_SOCKET ("/path" or "@abstract"), sent non-blocking. Not
// for the per-tick path: the watchdog ping comes from the supervising thread, at most every
// half watchdog period, and only while the loop's tick counter advances.

#include <cstdint>

namespace mrd::firmware::platform {

class SystemdNotifier {
 public:
  // Reads NOTIFY_SOCKET and WATCHDOG_USEC; without them every call does nothing.
  SystemdNotifier();
  ~SystemdNotifier();
  SystemdNotifier(const SystemdNotifier&) = delete;
  SystemdNotifier& operator=(const SystemdNotifier&) = delete;

  bool enabled() const { return fd_ >= 0; }
  // Interval between watchdog pings [ns]: WATCHDOG_USEC / 2; 0 without a watchdog.
  std::int64_t watchdog_interval_ns() const { return interval_ns_; }
  // Sends one message (e.g. "READY=1", "STOPPING=1"); false when not sent.
  bool Send(const char* message) const;
  // Sends "WATCHDOG=1" when the interval has passed since the last ping and ticks advanced
  // (a stalled loop is not pinged, so systemd restarts it). now_ns: monotonic [ns].
  void Ping(std::int64_t now_ns, std::uint64_t ticks);

 private:
  int fd_ = -1;
  char path_[108] = {};
  unsigned path_length_ = 0;
  std::int64_t interval_ns_ = 0;
  std::int64_t last_ping_ns_ = 0;
  std::uint64_t last_ticks_ = 0;
};

}  // namespace mrd::firmware::platform
