#include "mrd/canbus/can_iface.hpp"

#include <fcntl.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <ctime>

namespace mrd::canbus {
namespace {

bool IsDisconnect(int err) {
  return err == EPIPE || err == ECONNRESET || err == ENOTCONN || err == ENETDOWN || err == ENODEV ||
         err == ENXIO || err == EBADF;
}

}  // namespace

const char* CanResultName(CanResult result) {
  switch (result) {
    case CanResult::kOk:
      return "ok";
    case CanResult::kEmpty:
      return "empty";
    case CanResult::kDisconnected:
      return "disconnected";
    case CanResult::kBusOff:
      return "bus_off";
    case CanResult::kBadFrame:
      return "bad_frame";
    case CanResult::kOverflow:
      return "overflow";
    case CanResult::kTimedOut:
      return "timed_out";
    case CanResult::kError:
      return "error";
  }
  return "?";
}

std::int64_t MonotonicNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void CanIface::Attach(int fd) {
  Close();
  fd_ = fd;
  if (fd_ >= 0) {
    const int flags = fcntl(fd_, F_GETFL, 0);
    if (flags >= 0) fcntl(fd_, F_SETFL, flags | O_NONBLOCK);
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
  alignas(can_frame) unsigned char buf[sizeof(canfd_frame)];
  const ssize_t n = recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return CanResult::kEmpty;
    if (IsDisconnect(errno)) return Lost();
    ++stats_.rx_errors;
    return CanResult::kError;
  }
  if (n == 0) return Lost();  // orderly shutdown of the peer (SOCK_SEQPACKET EOF)
  if (static_cast<std::size_t>(n) != sizeof(can_frame)) {
    ++stats_.rx_bad;
    return CanResult::kBadFrame;
  }
  __builtin_memcpy(frame, buf, sizeof(can_frame));
  *stamp_ns = MonotonicNs();
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
