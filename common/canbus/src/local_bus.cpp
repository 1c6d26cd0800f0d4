#include "mrd/canbus/local_bus.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/common/clock.hpp"

namespace mrd::canbus {
namespace {

constexpr int kBacklog = 16;
constexpr int kMaxFramesPerNodeRound = 64;            // fairness: bounded work per node per Step
constexpr std::int64_t kProbeWaitNs = 200'000'000;    // a full backlog: retry this long [ns]
constexpr std::int64_t kAcceptPauseNs = 100'000'000;  // accept() failing: listener rests [ns]

void SleepNs(std::int64_t ns) {
  const timespec ts{0, static_cast<long>(ns)};
  nanosleep(&ts, nullptr);
}

// Whether a relay serves addr. Never blocks: a non-blocking connect succeeds at once when the
// relay's backlog has room, fails with ECONNREFUSED when nobody listens (a socket file left by
// a dead relay), and with EAGAIN when the backlog is full: the owner is alive but does not
// accept (stopped, or busy). That is retried for kProbeWaitNs and then counts as served.
bool Listening(const sockaddr_un& addr) {
  const std::int64_t until = common::MonotonicNs() + kProbeWaitNs;
  while (true) {
    const int probe = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (probe < 0) return true;  // cannot tell: never replace what may be a live relay
    const int rc = connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
    const int err = errno;
    close(probe);
    if (rc == 0) return true;
    if (err != EAGAIN && err != EINTR) return false;
    if (common::MonotonicNs() >= until) return true;
    SleepNs(10'000'000);
  }
}

}  // namespace

bool LocalBusRelay::Open(const std::string& path, std::string* error) {
  Close();
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr.sun_path) {
    *error = "local bus: socket path '" + path + "' is empty or longer than " +
             std::to_string(sizeof addr.sun_path - 1) + " characters";
    return false;
  }
  std::memcpy(addr.sun_path, path.c_str(), path.size());
  struct stat st {};
  if (lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      *error = "local bus: " + path + " exists and is not a socket";
      return false;
    }
    if (Listening(addr)) {
      *error = "local bus: " + path +
               " is already served by another relay (or by one that does not accept "
               "connections: stopped?)";
      return false;
    }
    unlink(path.c_str());  // left by a relay that died
  }
  // Bound and listening under a temporary name first, then renamed into place: a node that
  // sees the path can connect at once (no window between bind and listen).
  const std::string staging = path + ".new";
  sockaddr_un staged{};
  staged.sun_family = AF_UNIX;
  if (staging.size() >= sizeof staged.sun_path) {
    *error = "local bus: socket path '" + path + "' is longer than " +
             std::to_string(sizeof staged.sun_path - 5) + " characters";
    return false;
  }
  std::memcpy(staged.sun_path, staging.c_str(), staging.size());
  unlink(staging.c_str());
  listen_fd_ = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0 ||
      bind(listen_fd_, reinterpret_cast<const sockaddr*>(&staged), sizeof staged) != 0 ||
      listen(listen_fd_, kBacklog) != 0 || rename(staging.c_str(), path.c_str()) != 0) {
    *error = "local bus: cannot listen on " + path + ": " + std::strerror(errno);
    if (listen_fd_ >= 0) close(listen_fd_);
    listen_fd_ = -1;
    unlink(staging.c_str());
    return false;
  }
  path_ = path;
  spare_fd_ = open("/dev/null", O_RDONLY | O_CLOEXEC);
  listen_paused_until_ns_ = 0;
  return true;
}

void LocalBusRelay::Close() {
  for (int fd : nodes_) close(fd);
  nodes_.clear();
  if (listen_fd_ >= 0) {
    close(listen_fd_);
    listen_fd_ = -1;
    unlink(path_.c_str());
  }
  if (spare_fd_ >= 0) close(spare_fd_);
  spare_fd_ = -1;
}

void LocalBusRelay::Drop(std::size_t i) {
  close(nodes_[i]);
  nodes_.erase(nodes_.begin() + static_cast<std::ptrdiff_t>(i));
  left_.fetch_add(1, std::memory_order_relaxed);
}

void LocalBusRelay::Broadcast(const void* frame) {
  in_.fetch_add(1, std::memory_order_relaxed);
  if (!held_) {
    Forward(nodes_.size(), frame, common::MonotonicNs());
    return;
  }
  if (log_ != nullptr) log_(log_context_, frame, true);
  if (held_count_ == kHeldFrames) Flush();
  LocalBusPacket& packet = held_packets_[held_count_++];
  std::memcpy(&packet.frame, frame, sizeof(can_frame));
  packet.stamp_ns = common::MonotonicNs();
}

void LocalBusRelay::Flush() {
  const std::size_t count = held_count_;
  if (count == 0) return;
  held_count_ = 0;
  iovec iov[kHeldFrames];
  mmsghdr msgs[kHeldFrames];
  for (std::size_t k = 0; k < count; ++k) {
    iov[k] = {&held_packets_[k], sizeof(LocalBusPacket)};
    msgs[k] = {};
    msgs[k].msg_hdr.msg_iov = &iov[k];
    msgs[k].msg_hdr.msg_iovlen = 1;
  }
  for (const int fd : nodes_) {
    // Each packet once: a full node loses the rest (as a full FIFO), a partial send goes on
    // with the packets after the ones it took.
    std::size_t sent = 0;
    while (sent < count) {
      const int n = sendmmsg(fd, msgs + sent, static_cast<unsigned>(count - sent),
                             MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    out_.fetch_add(sent, std::memory_order_relaxed);
    dropped_.fetch_add(count - sent, std::memory_order_relaxed);
  }
}

void LocalBusRelay::Forward(std::size_t from, const void* frame, std::int64_t stamp_ns) {
  if (log_ != nullptr) log_(log_context_, frame, from == nodes_.size());
  LocalBusPacket packet;
  std::memcpy(&packet.frame, frame, sizeof(can_frame));
  packet.stamp_ns = stamp_ns;
  for (std::size_t j = 0; j < nodes_.size(); ++j) {
    if (j == from) continue;
    if (send(nodes_[j], &packet, sizeof packet, MSG_DONTWAIT | MSG_NOSIGNAL) ==
        static_cast<ssize_t>(sizeof packet)) {
      out_.fetch_add(1, std::memory_order_relaxed);
    } else {
      dropped_.fetch_add(1, std::memory_order_relaxed);  // full (or leaving: seen on its recv)
    }
  }
}

void LocalBusRelay::Accept() {
  while (true) {
    const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd >= 0) {
      (void)EnableReceiveStamps(fd);  // else frames are stamped when the relay reads them
      nodes_.push_back(fd);
      joined_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    if (errno == EAGAIN || errno == EWOULDBLOCK) return;
    if (errno == EINTR || errno == ECONNABORTED) continue;
    if ((errno == EMFILE || errno == ENFILE) && spare_fd_ >= 0) {
      // Out of descriptors: the spare one makes room to take the pending connection and
      // close it (the node sees EOF), so it does not keep the listener readable.
      close(spare_fd_);
      const int refused = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      const int err = errno;
      if (refused >= 0) {
        close(refused);
        refused_.fetch_add(1, std::memory_order_relaxed);
      }
      spare_fd_ = open("/dev/null", O_RDONLY | O_CLOEXEC);
      if (refused >= 0) continue;
      if (err == EAGAIN || err == EWOULDBLOCK) return;
    }
    // No spare descriptor, or another failure (ENOBUFS, ENOMEM): rest the listener a while
    // instead of polling it readable in a loop.
    listen_paused_until_ns_ = common::MonotonicNs() + kAcceptPauseNs;
    return;
  }
}

bool LocalBusRelay::Step(int timeout_ms) {
  if (listen_fd_ < 0) return false;
  Flush();
  std::vector<pollfd>& fds = fds_;
  fds.clear();
  const bool listening = common::MonotonicNs() >= listen_paused_until_ns_;
  if (listening && listen_paused_until_ns_ != 0 && spare_fd_ < 0) {
    spare_fd_ = open("/dev/null", O_RDONLY | O_CLOEXEC);
  }
  if (!listening && timeout_ms > static_cast<int>(kAcceptPauseNs / 1'000'000)) {
    timeout_ms = static_cast<int>(kAcceptPauseNs / 1'000'000);
  }
  fds.push_back({listening ? listen_fd_ : -1, POLLIN, 0});
  for (int fd : nodes_) fds.push_back({fd, POLLIN, 0});
  if (poll(fds.data(), fds.size(), timeout_ms) <= 0) return false;
  // Nodes first (indices match nodes_ as polled), newest last; removals go backwards. Each
  // node's waiting packets are read a batch per system call (a lockstep period's frames in
  // one).
  std::vector<char>& gone = gone_;
  gone.assign(nodes_.size(), 0);
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    if ((fds[i + 1].revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
    int taken = 0;
    while (taken < kMaxFramesPerNodeRound && gone[i] == 0) {
      const auto room = static_cast<std::size_t>(kMaxFramesPerNodeRound - taken);
      const int n = ReceiveStampedBatch(nodes_[i], rx_, room < kRxBatch ? room : kRxBatch);
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) break;
      if (n <= 0) {
        gone[i] = 1;
        break;
      }
      taken += n;
      for (int k = 0; k < n; ++k) {
        const StampedPacket& p = rx_[k];
        if (p.size == 0) {  // EOF: the node left
          gone[i] = 1;
          break;
        }
        if (p.truncated || p.size != sizeof(can_frame)) {
          bad_.fetch_add(1, std::memory_order_relaxed);
          continue;
        }
        in_.fetch_add(1, std::memory_order_relaxed);
        Forward(i, p.data, p.stamp_ns);
        if (tap_ != nullptr) tap_(tap_context_, p.data, p.stamp_ns);
      }
      if (static_cast<std::size_t>(n) < kRxBatch) break;  // the node's socket is drained
    }
  }
  for (std::size_t i = gone.size(); i-- > 0;) {
    if (gone[i] != 0) Drop(i);
  }
  if ((fds[0].revents & POLLIN) != 0) Accept();
  return true;
}

void LocalBusRelay::Run(const std::atomic<bool>& stop) {
  while (!stop.load(std::memory_order_relaxed)) Step(20);
}

RelayStats LocalBusRelay::stats() const {
  RelayStats s;
  s.nodes_joined = joined_.load(std::memory_order_relaxed);
  s.nodes_left = left_.load(std::memory_order_relaxed);
  s.frames_in = in_.load(std::memory_order_relaxed);
  s.frames_out = out_.load(std::memory_order_relaxed);
  s.frames_dropped = dropped_.load(std::memory_order_relaxed);
  s.bad_packets = bad_.load(std::memory_order_relaxed);
  s.nodes_refused = refused_.load(std::memory_order_relaxed);
  return s;
}

}  // namespace mrd::canbus
