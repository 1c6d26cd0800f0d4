#include "modbus_link.hpp"

#include <fcntl.h>
#include <modbus/modbus.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "mrd/common/clock.hpp"

namespace mrd::firmware {

namespace {

namespace mb = mrd::protocol::modbus;

// errno of a failed send/receive on the link.
IoError Classify(int err) {
  if (err == ECONNRESET || err == EPIPE || err == ECONNREFUSED || err == ENOTCONN || err == EBADF ||
      err == EIO || err == ENXIO || err == ENOENT || err == EHOSTUNREACH || err == ENETUNREACH ||
      err == ECONNABORTED || err == ETIMEDOUT) {
    return IoError::kDisconnected;
  }
  return IoError::kSystem;
}

// Bytes of the reply to a request PDU (RTU: its time on the wire).
int RtuReplyBytes(const std::uint8_t* pdu) {
  const int count = (pdu[3] << 8) | pdu[4];
  if (pdu[0] == mb::kFcReadHolding || pdu[0] == 0x04) return 5 + 2 * count;
  if (pdu[0] == 0x01 || pdu[0] == 0x02) return 5 + (count + 7) / 8;  // coils, discrete inputs
  return 8;
}

}  // namespace

ModbusLink::~ModbusLink() {
  Close();
  if (ctx_ != nullptr) modbus_free(ctx_);
}

bool ModbusLink::Create(std::string* error) {
  if (ctx_ != nullptr) return true;
  const bool tcp = config_.mode == ModbusMode::kTcp;
  if (tcp) {
    const std::string port = std::to_string(config_.port);
    ctx_ = modbus_new_tcp_pi(config_.host.c_str(), port.c_str());
  } else {
    ctx_ = modbus_new_rtu(config_.device.c_str(), config_.baud, config_.parity, config_.data_bits,
                          config_.stop_bits);
  }
  if (ctx_ == nullptr) {
    *error = std::string("modbus: cannot create the ") + (tcp ? "TCP" : "RTU") +
             " context: " + modbus_strerror(errno);
    return false;
  }
  if (modbus_set_slave(ctx_, config_.slave) != 0) {
    *error = std::string("modbus: slave ") + std::to_string(config_.slave) + ": " +
             modbus_strerror(errno);
    return false;
  }
  // libmodbus uses the response timeout as the TCP connect timeout.
  const std::int64_t ns = config_.response_timeout_ns;
  modbus_set_response_timeout(ctx_, static_cast<std::uint32_t>(ns / 1'000'000'000),
                              static_cast<std::uint32_t>((ns % 1'000'000'000) / 1000));
  return true;
}

bool ModbusLink::Resolve() {
  if (addr_count_ > 0) return true;
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_protocol = IPPROTO_TCP;
  hints.ai_flags = AI_ADDRCONFIG;
  char service[8];
  std::snprintf(service, sizeof service, "%d", config_.port);
  addrinfo* found = nullptr;
  if (getaddrinfo(config_.host.c_str(), service, &hints, &found) != 0 || found == nullptr) {
    errno = EHOSTUNREACH;
    return false;
  }
  for (const addrinfo* a = found; a != nullptr && addr_count_ < kMaxAddrs; a = a->ai_next) {
    if (a->ai_addrlen > sizeof(sockaddr_storage)) continue;
    Addr& slot = addrs_[addr_count_++];
    std::memcpy(&slot.addr, a->ai_addr, a->ai_addrlen);
    slot.len = a->ai_addrlen;
  }
  freeaddrinfo(found);
  if (addr_count_ == 0) errno = EAFNOSUPPORT;
  return addr_count_ > 0;
}

int ModbusLink::ConnectTo(int i) const {
  const Addr& a = addrs_[i];
  const int fd = socket(a.addr.ss_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) return -1;
  const int on = 1;
  (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);  // as libmodbus
  int err = 0;
  if (connect(fd, reinterpret_cast<const sockaddr*>(&a.addr), a.len) != 0) {
    err = errno;
    if (err == EINPROGRESS) {
      // Bounded by the response timeout (libmodbus's connect timeout).
      const std::int64_t until = common::MonotonicNs() + config_.response_timeout_ns;
      pollfd p{fd, POLLOUT, 0};
      int rc = 0;
      do {
        const std::int64_t left = until - common::MonotonicNs();
        if (left <= 0) {
          rc = 0;
          break;
        }
        const timespec ts{static_cast<time_t>(left / 1'000'000'000),
                          static_cast<long>(left % 1'000'000'000)};
        rc = ppoll(&p, 1, &ts, nullptr);
      } while (rc < 0 && errno == EINTR);
      socklen_t len = sizeof err;
      if (rc <= 0) {
        err = rc == 0 ? ETIMEDOUT : errno;
      } else if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0) {
        err = errno;
      }
    }
  }
  if (err != 0) {
    close(fd);
    errno = err;
    return -1;
  }
  return fd;
}

bool ModbusLink::Open() {
  if (fd_ >= 0) return true;
  broken_ = false;
  if (config_.mode == ModbusMode::kTcp) {
    // Connected here, to the addresses resolved once: libmodbus's modbus_connect resolves the
    // host on every call (getaddrinfo allocates), and a reconnect runs on the worker beside
    // the loop. libmodbus owns the descriptor from here (modbus_close closes it).
    if (!Resolve()) return false;
    int fd = -1;
    for (int i = 0; i < addr_count_ && fd < 0; ++i) fd = ConnectTo(i);
    if (fd < 0) return false;
    modbus_set_socket(ctx_, fd);
    fd_ = fd;
    return true;
  }
  if (modbus_connect(ctx_) != 0) return false;
  fd_ = modbus_get_socket(ctx_);
  const int flags = fcntl(fd_, F_GETFL);
  if (flags < 0 || fcntl(fd_, F_SETFL, flags | O_NONBLOCK) != 0) {
    const int err = errno;
    Close();
    errno = err;
    return false;
  }
  if (config_.mode == ModbusMode::kRtu) tcflush(fd_, TCIOFLUSH);
  return true;
}

void ModbusLink::Close() {
  if (fd_ >= 0) modbus_close(ctx_);
  fd_ = -1;
}

std::int64_t ModbusLink::WireNs(int bytes) const {
  return mb::RtuFrameNs(bytes, config_.baud, config_.data_bits, config_.parity, config_.stop_bits);
}

ModbusLink::Result ModbusLink::Broken(IoError e, IoError* why) {
  broken_ = true;
  *why = e;
  return Result::kFailed;
}

ModbusLink::Result ModbusLink::Unfinished(Wait w, bool mid_frame, IoError* why) {
  if (w == Wait::kHangUp) return Broken(IoError::kDisconnected, why);
  if (mid_frame) broken_ = true;  // the frame's rest would follow on the stream
  if (w == Wait::kAbandoned) return Result::kAbandoned;
  *why = IoError::kTimeout;
  return Result::kFailed;
}

ModbusLink::Wait ModbusLink::WaitFor(short events, std::int64_t deadline_ns, Phase phase,
                                     int wake_fd, Interrupt* interrupt) {
  while (true) {
    const std::int64_t left = deadline_ns - common::MonotonicNs();
    if (left <= 0) return Wait::kTimeout;
    const timespec ts{static_cast<time_t>(left / 1'000'000'000),
                      static_cast<long>(left % 1'000'000'000)};
    pollfd p[2] = {{fd_, events, 0}, {wake_fd, POLLIN, 0}};
    const int r = ppoll(p, wake_fd >= 0 ? 2 : 1, &ts, nullptr);
    if (r < 0 && errno != EINTR) return Wait::kReady;  // the next system call reports it
    if (r <= 0) continue;
    if (wake_fd >= 0 && (p[1].revents & POLLIN) != 0) {
      std::uint64_t n = 0;
      (void)!read(wake_fd, &n, sizeof n);
      if (interrupt != nullptr && interrupt->Abandon(phase)) return Wait::kAbandoned;
    }
    if ((p[0].revents & events) != 0) return Wait::kReady;
    if ((p[0].revents & (POLLHUP | POLLERR | POLLNVAL)) != 0) return Wait::kHangUp;
  }
}

ModbusLink::Result ModbusLink::Send(const std::uint8_t* adu, int len, std::int64_t deadline_ns,
                                    IoError* why, int wake_fd, Interrupt* interrupt) {
  const bool tcp = config_.mode == ModbusMode::kTcp;
  int sent = 0;
  while (sent < len) {
    const auto rest = static_cast<std::size_t>(len - sent);
    const ssize_t n =
        tcp ? send(fd_, adu + sent, rest, MSG_NOSIGNAL) : write(fd_, adu + sent, rest);
    if (n > 0) {
      sent += static_cast<int>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      const Wait w = WaitFor(POLLOUT, deadline_ns, Phase::kMidFrame, wake_fd, interrupt);
      if (w == Wait::kReady) continue;
      return Unfinished(w, tcp && sent > 0, why);  // TCP: half a request on the stream
    }
    return Broken(n < 0 ? Classify(errno) : IoError::kDisconnected, why);
  }
  return Result::kOk;
}

ModbusLink::Result ModbusLink::ReadExactly(std::uint8_t* buf, int n, std::int64_t deadline_ns,
                                           Phase phase, IoError* why, int wake_fd,
                                           Interrupt* interrupt) {
  int have = 0;
  while (have < n) {
    const ssize_t r = read(fd_, buf + have, static_cast<std::size_t>(n - have));
    if (r > 0) {
      have += static_cast<int>(r);
      continue;
    }
    if (r == 0 && config_.mode == ModbusMode::kTcp) return Broken(IoError::kDisconnected, why);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0 && errno != EAGAIN && errno != EWOULDBLOCK) return Broken(Classify(errno), why);
    // Nothing to read yet (a serial line in raw mode with VMIN = 0 reads 0 bytes).
    const Phase now = have > 0 ? Phase::kMidFrame : phase;
    const Wait w = WaitFor(POLLIN, deadline_ns, now, wake_fd, interrupt);
    if (w != Wait::kReady) return Unfinished(w, now == Phase::kMidFrame, why);
  }
  return Result::kOk;
}

ModbusLink::Result ModbusLink::ReceiveTcp(std::uint8_t* reply, int* reply_len,
                                          std::int64_t deadline_ns, IoError* why, int wake_fd,
                                          Interrupt* interrupt) {
  while (true) {
    Result r =
        ReadExactly(buf_, mb::kMbapSize, deadline_ns, Phase::kReply, why, wake_fd, interrupt);
    if (r != Result::kOk) return r;
    const mb::Mbap h = mb::GetMbap(buf_);
    if (!mb::MbapLengthValid(h.length)) return Broken(IoError::kRejectedFrame, why);
    const int pdu_len = h.length - 1;
    r = ReadExactly(buf_ + mb::kMbapSize, pdu_len, deadline_ns, Phase::kMidFrame, why, wake_fd,
                    interrupt);
    if (r != Result::kOk) return r;
    if (h.protocol != 0) {  // not a Modbus frame (framed by its length: the stream is in step)
      *why = IoError::kRejectedFrame;
      return Result::kFailed;
    }
    if (h.transaction != transaction_) continue;  // a late reply to an earlier request
    if (h.unit != unit_) {
      *why = IoError::kRejectedFrame;
      return Result::kFailed;
    }
    std::memcpy(reply, buf_ + mb::kMbapSize, static_cast<std::size_t>(pdu_len));
    *reply_len = pdu_len;
    return Result::kOk;
  }
}

ModbusLink::Result ModbusLink::ReceiveRtu(std::uint8_t function, std::uint8_t* reply,
                                          int* reply_len, std::int64_t deadline_ns, IoError* why,
                                          int wake_fd, Interrupt* interrupt) {
  int have = 0;
  int len = 0;
  while (true) {
    if (len > 0 && have >= len) {
      // A whole frame from this unit that answers another function: a late reply to an
      // earlier request (RTU has no transaction id). Dropped; the wait goes on.
      const bool ours = buf_[1] == function || buf_[1] == (function | mb::kExceptionFlag);
      if (ours || buf_[0] != unit_ || !mb::RtuCrcValid(buf_, len)) break;
      std::memmove(buf_, buf_ + len, static_cast<std::size_t>(have - len));
      have -= len;
      len = mb::RtuReplyLength(buf_, have);
      continue;
    }
    const ssize_t r = read(fd_, buf_ + have, sizeof buf_ - static_cast<std::size_t>(have));
    if (r > 0) {
      have += static_cast<int>(r);
      len = mb::RtuReplyLength(buf_, have);
      continue;
    }
    if (len < 0 || len > static_cast<int>(sizeof buf_)) {  // no length to wait for
      *why = IoError::kRejectedFrame;
      return Result::kFailed;
    }
    if (r < 0 && errno == EINTR) continue;
    if (r < 0 && errno != EAGAIN && errno != EWOULDBLOCK) return Broken(Classify(errno), why);
    const Wait w = WaitFor(POLLIN, deadline_ns, have > 0 ? Phase::kMidFrame : Phase::kReply,
                           wake_fd, interrupt);
    // A torn frame leaves the link usable: the next request flushes the line first.
    if (w != Wait::kReady) return Unfinished(w, /*mid_frame=*/false, why);
  }
  if (!mb::RtuCrcValid(buf_, len)) {
    *why = IoError::kCrc;
    return Result::kFailed;
  }
  if (buf_[0] != unit_) {  // another unit answered
    *why = IoError::kRejectedFrame;
    return Result::kFailed;
  }
  std::memcpy(reply, buf_ + 1, static_cast<std::size_t>(len - 3));
  *reply_len = len - 3;
  return Result::kOk;
}

ModbusLink::Result ModbusLink::Transact(const std::uint8_t* pdu, int len, std::uint8_t* reply,
                                        int* reply_len, IoError* why, int wake_fd,
                                        Interrupt* interrupt) {
  if (fd_ < 0 || broken_) {
    *why = IoError::kDisconnected;
    return Result::kFailed;
  }
  std::uint8_t adu[mb::kMaxTcpAdu + 8];
  int n = 0;
  std::int64_t wait_ns = config_.response_timeout_ns;
  if (config_.mode == ModbusMode::kTcp) {
    ++transaction_;
    mb::PutMbap({transaction_, 0, static_cast<std::uint16_t>(len + 1), unit_}, adu);
    std::memcpy(adu + mb::kMbapSize, pdu, static_cast<std::size_t>(len));
    n = mb::kMbapSize + len;
  } else {
    adu[0] = unit_;
    std::memcpy(adu + 1, pdu, static_cast<std::size_t>(len));
    n = mb::PutRtuCrc(adu, len + 1);
    wait_ns += WireNs(n) + WireNs(RtuReplyBytes(pdu));
    tcflush(fd_, TCIFLUSH);  // no transaction id: nothing older may be taken for the reply
  }
  const std::int64_t deadline = common::MonotonicNs() + wait_ns;
  const Result r = Send(adu, n, deadline, why, wake_fd, interrupt);
  if (r != Result::kOk) return r;
  return config_.mode == ModbusMode::kTcp
             ? ReceiveTcp(reply, reply_len, deadline, why, wake_fd, interrupt)
             : ReceiveRtu(pdu[0], reply, reply_len, deadline, why, wake_fd, interrupt);
}

bool ModbusLink::Quiet(int wake_fd, Interrupt* interrupt) {
  for (int round = 0; round < kMaxQuietRounds && fd_ >= 0; ++round) {
    tcflush(fd_, TCIFLUSH);
    switch (WaitFor(POLLIN, common::MonotonicNs() + config_.response_timeout_ns, Phase::kQuiet,
                    wake_fd, interrupt)) {
      case Wait::kTimeout:
        return true;
      case Wait::kAbandoned:
        return false;
      case Wait::kReady:
        break;  // something arrived: discard it and wait again
      case Wait::kHangUp:
        return true;  // the next request finds the link down
    }
  }
  if (fd_ >= 0) tcflush(fd_, TCIFLUSH);
  return true;
}

}  // namespace mrd::firmware
