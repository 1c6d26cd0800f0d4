#include "mrd/canbus/can_iface.hpp"

#include <fcntl.h>
#include <linux/can/error.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstddef>
#include <ctime>

#include "mrd/common/clock.hpp"

namespace mrd::canbus {
namespace {

std::int64_t Ns(const timespec& ts) {
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

bool IsDisconnect(int err) {
  return err == EPIPE || err == ECONNRESET || err == ENOTCONN || err == ENETDOWN || err == ENODEV ||
         err == ENXIO || err == EBADF;
}

}  // namespace

std::int64_t ArrivalStamp(const timespec& realtime_stamp, std::int64_t monotonic_now_ns,
                          std::int64_t realtime_now_ns) {
  const std::int64_t age = realtime_now_ns - Ns(realtime_stamp);
  return monotonic_now_ns - (age >= 0 ? age : kUnknownAgeNs);
}

bool EnableReceiveStamps(int fd) {
  const int on = 1;
  return setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) == 0;
}

ssize_t ReceiveStamped(int fd, void* buf, std::size_t size, std::int64_t* stamp_ns,
                       bool* truncated) {
  iovec iov{buf, size};
  alignas(cmsghdr) unsigned char control[CMSG_SPACE(sizeof(timespec)) * 2];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = recvmsg(fd, &msg, MSG_DONTWAIT);
  if (n < 0) return n;
  *stamp_ns = common::MonotonicNs();
  *truncated = (msg.msg_flags & MSG_TRUNC) != 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS &&
        c->cmsg_len >= CMSG_LEN(sizeof(timespec))) {
      timespec ts{};
      __builtin_memcpy(&ts, CMSG_DATA(c), sizeof ts);
      if (ts.tv_sec == 0 && ts.tv_nsec == 0) continue;
      // Both clocks now: the kernel stamp's age is measured on the wall clock over this short
      // interval and applied to the monotonic one. The wall clock is read between two
      // monotonic reads, the tightest of a few tries kept: a preemption between the reads
      // would otherwise add itself to the age.
      std::int64_t best_gap = INT64_MAX, mono_mid = 0, real_now = 0;
      for (int i = 0; i < 4 && best_gap > 2'000; ++i) {
        timespec m0{}, r{}, m1{};
        clock_gettime(CLOCK_MONOTONIC, &m0);
        clock_gettime(CLOCK_REALTIME, &r);
        clock_gettime(CLOCK_MONOTONIC, &m1);
        const std::int64_t gap = Ns(m1) - Ns(m0);
        if (gap < best_gap) {
          best_gap = gap;
          mono_mid = Ns(m0) + gap / 2;
          real_now = Ns(r);
        }
      }
      *stamp_ns = ArrivalStamp(ts, mono_mid, real_now);
    }
  }
  return n;
}

void CanIface::Attach(int fd) {
  Close();
  fd_ = fd;
  if (fd_ >= 0) {
    const int flags = fcntl(fd_, F_GETFL, 0);
    if (flags >= 0) fcntl(fd_, F_SETFL, flags | O_NONBLOCK);
    (void)EnableReceiveStamps(fd_);  // else (not a socket) frames are stamped at the read
  }
}

void CanIface::Close() {
  if (fd_ >= 0) close(fd_);
  fd_ = -1;
  head_ = 0;
  count_ = 0;
}

CanResult CanIface::Lost() {
  ++stats_.disconnects;
  Close();
  return CanResult::kDisconnected;
}

CanResult CanIface::Receive(can_frame* frame, std::int64_t* stamp_ns) {
  if (fd_ < 0) return CanResult::kDisconnected;
  // Room for a CAN FD frame, so an oversized packet shows as such instead of truncating.
  alignas(LocalBusPacket) unsigned char buf[sizeof(canfd_frame)];
  std::int64_t stamp = 0;
  bool truncated = false;
  const ssize_t n = ReceiveStamped(fd_, buf, sizeof buf, &stamp, &truncated);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return CanResult::kEmpty;
    if (IsDisconnect(errno)) return Lost();
    ++stats_.rx_errors;
    return CanResult::kError;
  }
  if (n == 0) return Lost();  // orderly shutdown of the peer (SOCK_SEQPACKET EOF)
  if (truncated || (static_cast<std::size_t>(n) != sizeof(can_frame) &&
                    static_cast<std::size_t>(n) != sizeof(LocalBusPacket))) {
    ++stats_.rx_bad;
    return CanResult::kBadFrame;
  }
  __builtin_memcpy(frame, buf, sizeof(can_frame));
  if (static_cast<std::size_t>(n) == sizeof(LocalBusPacket)) {
    // The relay's stamp: when the frame entered the bus (never later than our own).
    std::int64_t bus_stamp = 0;
    __builtin_memcpy(&bus_stamp, buf + offsetof(LocalBusPacket, stamp_ns), sizeof bus_stamp);
    if (bus_stamp < stamp) stamp = bus_stamp;
  }
  *stamp_ns = stamp;
  if ((frame->can_id & CAN_ERR_FLAG) != 0) {
    ++stats_.rx_errors;
    if ((frame->can_id & CAN_ERR_BUSOFF) != 0) {
      ++stats_.bus_off;
      return CanResult::kBusOff;
    }
    return CanResult::kError;
  }
  ++stats_.rx_frames;
  return CanResult::kOk;
}

bool CanIface::Readable() const {
  if (fd_ < 0) return false;
  pollfd p{fd_, POLLIN, 0};
  return poll(&p, 1, 0) > 0 && (p.revents & POLLIN) != 0;
}

CanResult CanIface::Send(const can_frame& frame, std::int64_t deadline_ns, std::int64_t now_ns) {
  if (fd_ < 0) return CanResult::kDisconnected;
  if (count_ == kTxQueue) {
    // Make room by dropping what has expired; still full: refuse the new frame.
    const CanResult r = Flush(now_ns);
    if (r == CanResult::kDisconnected) return r;
    if (count_ == kTxQueue) {
      ++stats_.tx_overflow;
      return CanResult::kOverflow;
    }
  }
  queue_[(head_ + count_) % kTxQueue] = {frame, deadline_ns};
  ++count_;
  return Flush(now_ns);
}

CanResult CanIface::Flush(std::int64_t now_ns) {
  if (fd_ < 0) return CanResult::kDisconnected;
  bool dropped = false;
  while (count_ > 0) {
    Slot& s = queue_[head_];
    if (now_ns > s.deadline_ns) {
      ++stats_.tx_timedout;
      dropped = true;
    } else {
      const ssize_t n = send(fd_, &s.frame, sizeof s.frame, MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS || errno == EINTR) break;
        if (IsDisconnect(errno) || errno == ECONNREFUSED) return Lost();
        ++stats_.tx_errors;  // the frame is refused for good: drop it
        head_ = (head_ + 1) % kTxQueue;
        --count_;
        return CanResult::kError;
      }
      ++stats_.tx_frames;
    }
    head_ = (head_ + 1) % kTxQueue;
    --count_;
  }
  return dropped ? CanResult::kTimedOut : CanResult::kOk;
}

}  // namespace mrd::canbus
