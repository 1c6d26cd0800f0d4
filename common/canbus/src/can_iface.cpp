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

namespace {

// The kernel's receive stamp (CLOCK_REALTIME) of a received message, if it carries one.
bool KernelStamp(msghdr& msg, timespec* ts) {
  bool found = false;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS &&
        c->cmsg_len >= CMSG_LEN(sizeof(timespec))) {
      timespec t{};
      __builtin_memcpy(&t, CMSG_DATA(c), sizeof t);
      if (t.tv_sec == 0 && t.tv_nsec == 0) continue;
      *ts = t;
      found = true;
    }
  }
  return found;
}

// Both clocks now: a kernel stamp's age is measured on the wall clock over this short interval
// and applied to the monotonic one. The wall clock is read between two monotonic reads, the
// tightest of a few tries kept: a preemption between the reads would otherwise add itself to
// the age.
void ClockPair(std::int64_t* mono_mid, std::int64_t* real_now) {
  std::int64_t best_gap = INT64_MAX;
  for (int i = 0; i < 4 && best_gap > 2'000; ++i) {
    timespec m0{}, r{}, m1{};
    clock_gettime(CLOCK_MONOTONIC, &m0);
    clock_gettime(CLOCK_REALTIME, &r);
    clock_gettime(CLOCK_MONOTONIC, &m1);
    const std::int64_t gap = Ns(m1) - Ns(m0);
    if (gap < best_gap) {
      best_gap = gap;
      *mono_mid = Ns(m0) + gap / 2;
      *real_now = Ns(r);
    }
  }
}

}  // namespace

int ReceiveStampedBatch(int fd, StampedPacket* packets, std::size_t count) {
  if (count > kMaxStampedBatch) count = kMaxStampedBatch;
  if (count == 0) return 0;
  constexpr std::size_t kControl = CMSG_SPACE(sizeof(timespec)) * 2;
  alignas(cmsghdr) unsigned char control[kMaxStampedBatch][kControl];
  iovec iov[kMaxStampedBatch];
  mmsghdr msgs[kMaxStampedBatch];
  for (std::size_t k = 0; k < count; ++k) {
    iov[k] = {packets[k].data, sizeof packets[k].data};
    msgs[k] = {};
    msgs[k].msg_hdr.msg_iov = &iov[k];
    msgs[k].msg_hdr.msg_iovlen = 1;
    msgs[k].msg_hdr.msg_control = control[k];
    msgs[k].msg_hdr.msg_controllen = kControl;
  }
  const int n = recvmmsg(fd, msgs, static_cast<unsigned>(count), MSG_DONTWAIT, nullptr);
  if (n <= 0) return n < 0 ? -1 : 0;
  const std::int64_t read_ns = common::MonotonicNs();
  bool have_pair = false;
  std::int64_t mono_mid = 0, real_now = 0;
  for (int k = 0; k < n; ++k) {
    StampedPacket& p = packets[k];
    p.size = msgs[k].msg_len;
    p.truncated = (msgs[k].msg_hdr.msg_flags & MSG_TRUNC) != 0;
    p.stamp_ns = read_ns;
    timespec ts{};
    if (KernelStamp(msgs[k].msg_hdr, &ts)) {
      if (!have_pair) ClockPair(&mono_mid, &real_now);
      have_pair = true;
      p.stamp_ns = ArrivalStamp(ts, mono_mid, real_now);
    }
  }
  return n;
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
  timespec ts{};
  if (KernelStamp(msg, &ts)) {
    std::int64_t mono_mid = 0, real_now = 0;
    ClockPair(&mono_mid, &real_now);
    *stamp_ns = ArrivalStamp(ts, mono_mid, real_now);
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
  held_ = false;
  rx_head_ = rx_count_ = 0;
}

CanResult CanIface::Lost() {
  ++stats_.disconnects;
  Close();
  return CanResult::kDisconnected;
}

CanResult CanIface::Receive(can_frame* frame, std::int64_t* stamp_ns) {
  if (fd_ < 0) return CanResult::kDisconnected;
  if (rx_head_ == rx_count_) {
    rx_head_ = rx_count_ = 0;
    const int n = ReceiveStampedBatch(fd_, rx_.data(), rx_.size());
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return CanResult::kEmpty;
      if (IsDisconnect(errno)) return Lost();
      ++stats_.rx_errors;
      return CanResult::kError;
    }
    if (n == 0) return CanResult::kEmpty;
    rx_count_ = static_cast<std::size_t>(n);
  }
  return Take(rx_[rx_head_++], frame, stamp_ns);
}

// One packet read (ahead): a frame, an EOF, a wrong size or an error frame.
CanResult CanIface::Take(const StampedPacket& p, can_frame* frame, std::int64_t* stamp_ns) {
  const std::size_t n = p.size;
  if (n == 0) return Lost();  // orderly shutdown of the peer (SOCK_SEQPACKET EOF)
  if (p.truncated || (n != sizeof(can_frame) && n != sizeof(LocalBusPacket))) {
    ++stats_.rx_bad;
    return CanResult::kBadFrame;
  }
  std::int64_t stamp = p.stamp_ns;
  __builtin_memcpy(frame, p.data, sizeof(can_frame));
  if (n == sizeof(LocalBusPacket)) {
    // The relay's stamp: when the frame entered the bus (never later than our own).
    std::int64_t bus_stamp = 0;
    __builtin_memcpy(&bus_stamp, p.data + offsetof(LocalBusPacket, stamp_ns), sizeof bus_stamp);
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
  if (rx_head_ != rx_count_) return true;
  pollfd p{fd_, POLLIN, 0};
  return poll(&p, 1, 0) > 0 && (p.revents & POLLIN) != 0;
}

CanResult CanIface::Send(const can_frame& frame, std::int64_t deadline_ns, std::int64_t now_ns) {
  if (fd_ < 0) return CanResult::kDisconnected;
  if (held_ && now_ns > deadline_ns) {  // dropped at once, as Flush would (the rest stays held)
    ++stats_.tx_timedout;
    return CanResult::kTimedOut;
  }
  if (count_ == kTxQueue) {
    // Make room by dropping what has expired (a held queue: by writing it); still full: refuse
    // the new frame.
    const CanResult r = Flush(now_ns);
    if (r == CanResult::kDisconnected) return r;
    if (count_ == kTxQueue) {
      ++stats_.tx_overflow;
      return CanResult::kOverflow;
    }
  }
  queue_[(head_ + count_) % kTxQueue] = {frame, deadline_ns};
  ++count_;
  if (held_) return CanResult::kOk;  // Release writes it
  return Flush(now_ns);
}

CanResult CanIface::Flush(std::int64_t now_ns) {
  if (fd_ < 0) return CanResult::kDisconnected;
  bool dropped = false;
  while (count_ > 0) {
    if (now_ns > queue_[head_].deadline_ns) {
      ++stats_.tx_timedout;
      dropped = true;
      head_ = (head_ + 1) % kTxQueue;
      --count_;
      continue;
    }
    // The frames from the head up to the first expired one, in one call.
    iovec iov[kTxQueue];
    mmsghdr msgs[kTxQueue];
    std::size_t batch = 0;
    for (; batch < count_; ++batch) {
      Slot& s = queue_[(head_ + batch) % kTxQueue];
      if (now_ns > s.deadline_ns) break;
      iov[batch] = {&s.frame, sizeof s.frame};
      msgs[batch] = {};
      msgs[batch].msg_hdr.msg_iov = &iov[batch];
      msgs[batch].msg_hdr.msg_iovlen = 1;
    }
    const int n = sendmmsg(fd_, msgs, static_cast<unsigned>(batch), MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS || errno == EINTR) break;
      if (IsDisconnect(errno) || errno == ECONNREFUSED) return Lost();
      ++stats_.tx_errors;  // the frame is refused for good: drop it
      head_ = (head_ + 1) % kTxQueue;
      --count_;
      return CanResult::kError;
    }
    stats_.tx_frames += static_cast<std::uint64_t>(n);
    head_ = (head_ + static_cast<std::size_t>(n)) % kTxQueue;
    count_ -= static_cast<std::size_t>(n);
    // A short count: the next frame would block, or failed (the next call says which).
  }
  return dropped ? CanResult::kTimedOut : CanResult::kOk;
}

}  // namespace mrd::canbus
