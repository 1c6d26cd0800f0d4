#include "modbus_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <string>

#include "mrd/common/clock.hpp"

namespace mrd::hil {
namespace {

namespace mb = mrd::protocol::modbus;

constexpr int kPollMs = 20;                           // the stop request is seen this often
constexpr int kRtuPartialPollMs = 2;                  // while an RTU frame is incomplete
constexpr std::int64_t kAcceptPauseNs = 100'000'000;  // after EMFILE / ENFILE

void NonBlocking(int fd) { fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK); }

}  // namespace

bool ModbusServer::ListenTcp(const std::string& host, int port, std::string* error) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  if (inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1) {
    *error = "host must be an IPv4 address";
    return false;
  }
  listen_fd_ = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  const int one = 1;
  if (listen_fd_ < 0 || setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0 ||
      bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
      listen(listen_fd_, kListenBacklog) != 0) {
    *error = std::string("cannot listen: ") + std::strerror(errno);
    if (listen_fd_ >= 0) close(listen_fd_);
    listen_fd_ = -1;
    return false;
  }
  clients_.resize(kMaxClients);
  return true;
}

void ModbusServer::ServeRtu(int master_fd) {
  NonBlocking(master_fd);
  line_.fd = master_fd;
}

void ModbusServer::Start() {
  running_.store(true);
  thread_ = std::thread([this] { Run(); });
}

void ModbusServer::Stop() {
  if (thread_.joinable()) {
    running_.store(false);
    thread_.join();
  }
  for (Client& c : clients_) {
    if (c.fd >= 0) close(c.fd);
    c.fd = -1;
  }
  if (listen_fd_ >= 0) close(listen_fd_);
  listen_fd_ = -1;
  line_.fd = -1;  // the caller's
}

void ModbusServer::Run() {
  std::array<pollfd, kMaxClients + 1> fds{};
  std::array<Client*, kMaxClients + 1> owner{};
  while (running_.load()) {
    const std::int64_t now = common::MonotonicNs();
    std::size_t n = 0;
    if (line_.fd >= 0) {
      fds[n] = {line_.fd, static_cast<short>(POLLIN | (line_.out_len > 0 ? POLLOUT : 0)), 0};
      owner[n++] = &line_;
    }
    if (listen_fd_ >= 0 && now >= accept_paused_until_) {
      fds[n] = {listen_fd_, POLLIN, 0};
      owner[n++] = nullptr;
    }
    for (Client& c : clients_) {
      if (c.fd < 0) continue;
      fds[n] = {c.fd, static_cast<short>(POLLIN | (c.out_len > 0 ? POLLOUT : 0)), 0};
      owner[n++] = &c;
    }
    const int timeout = line_.fd >= 0 && line_.have > 0 ? kRtuPartialPollMs : kPollMs;
    const int ready = poll(fds.data(), n, timeout);
    const std::int64_t t = common::MonotonicNs();
    for (std::size_t i = 0; ready > 0 && i < n; ++i) {
      if (fds[i].revents == 0) continue;
      Client* c = owner[i];
      if (c == nullptr) {
        Accept(t);
      } else if (c == &line_) {
        if ((fds[i].revents & POLLOUT) != 0) Flush(line_);
        if ((fds[i].revents & (POLLIN | POLLHUP | POLLERR)) != 0) ReadRtu(t);
      } else {
        if ((fds[i].revents & POLLOUT) != 0) Flush(*c);
        if (c->fd >= 0 && (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) != 0) ReadTcp(*c, t);
      }
    }
    // A request must be complete in time; an RTU line that went quiet ends its frame.
    for (Client& c : clients_) {
      if (c.fd >= 0 && c.request_start_ns != 0 && t - c.request_start_ns > kRequestTimeoutNs) {
        Drop(c, /*refused=*/true);
      }
    }
    if (line_.fd >= 0 && line_.have > 0 && t - last_byte_ns_ > kRtuGapNs) {
      // A frame whose function gives no length (it gets ILLEGAL FUNCTION), or a torn one.
      if (line_.have >= 4 && mb::RtuCrcValid(line_.in.data(), static_cast<int>(line_.have))) {
        AnswerRtu(line_.in.data(), line_.have);
      } else {
        bank_.CountRejected();
      }
      line_.have = 0;
    }
  }
}

void ModbusServer::Accept(std::int64_t now) {
  while (true) {
    const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
        accept_paused_until_ = now + kAcceptPauseNs;  // no busy loop on a full table
      }
      return;  // EAGAIN: all taken; ECONNABORTED and the like: nothing to serve
    }
    const auto free =
        std::find_if(clients_.begin(), clients_.end(), [](const Client& c) { return c.fd < 0; });
    if (free == clients_.end()) {
      close(fd);  // over the limit
      bank_.CountRefused();
      continue;
    }
    free->fd = fd;
    free->have = 0;
    free->out_len = 0;
    free->request_start_ns = 0;
  }
}

void ModbusServer::ReadTcp(Client& c, std::int64_t now) {
  while (c.fd >= 0) {
    const ssize_t r = recv(c.fd, c.in.data() + c.have, c.in.size() - c.have, 0);
    if (r == 0) {
      Drop(c, /*refused=*/false);  // the client closed
      return;
    }
    if (r < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) Drop(c, /*refused=*/false);
      return;
    }
    if (c.have == 0) c.request_start_ns = now;
    c.have += static_cast<std::size_t>(r);
    // Every complete frame (MBAP length = unit id + PDU).
    while (c.fd >= 0 && c.have >= static_cast<std::size_t>(mb::kMbapSize)) {
      const mb::Mbap h = mb::GetMbap(c.in.data());
      if (!mb::MbapLengthValid(h.length)) {
        bank_.CountRejected();
        Drop(c, /*refused=*/false);  // the stream has no frames any more
        return;
      }
      const std::size_t len = mb::kMbapSize - 1 + h.length;
      if (c.have < len) break;
      AnswerTcp(c, c.in.data());
      if (c.fd < 0) return;
      std::memmove(c.in.data(), c.in.data() + len, c.have - len);
      c.have -= len;
      c.request_start_ns = c.have > 0 ? now : 0;
    }
  }
}

void ModbusServer::AnswerTcp(Client& c, const std::uint8_t* frame) {
  const mb::Mbap h = mb::GetMbap(frame);
  if (h.protocol != 0) {  // not a Modbus frame
    bank_.CountRejected();
    return;
  }
  const std::uint8_t* pdu = frame + mb::kMbapSize;
  const int len = h.length - 1;
  std::uint8_t adu[mb::kMaxTcpAdu];
  std::uint8_t* reply = adu + mb::kMbapSize;
  int reply_len = 0;
  if (bank_.Serves(h.unit) || h.unit == mb::kBroadcastUnit || h.unit == mb::kTcpDirectUnit) {
    reply_len = bank_.Answer(h.unit, pdu, len, reply).reply_len;
  } else {  // another unit: none behind this server
    reply[0] = static_cast<std::uint8_t>(pdu[0] | mb::kExceptionFlag);
    reply[1] = mb::kExGatewayNoResponse;
    reply_len = 2;
    bank_.CountRejected();
  }
  mb::PutMbap({h.transaction, 0, static_cast<std::uint16_t>(reply_len + 1), h.unit}, adu);
  if (!Queue(c, adu, static_cast<std::size_t>(mb::kMbapSize + reply_len))) {
    Drop(c, /*refused=*/true);  // replies piling up: the client does not read them
  }
}

void ModbusServer::ReadRtu(std::int64_t now) {
  while (true) {
    if (line_.have == line_.in.size()) {  // no frame is this long: line noise
      bank_.CountRejected();
      line_.have = 0;
    }
    const ssize_t r = read(line_.fd, line_.in.data() + line_.have, line_.in.size() - line_.have);
    if (r <= 0) {
      if (r < 0 && errno == EIO) {  // nobody has the slave open: no busy loop
        const timespec pause{0, 5'000'000};
        nanosleep(&pause, nullptr);
      }
      return;
    }
    line_.have += static_cast<std::size_t>(r);
    last_byte_ns_ = now;
    // Every complete frame whose function gives its length.
    while (line_.have >= 2) {
      const int len = mb::RtuRequestLength(line_.in.data(), static_cast<int>(line_.have));
      if (len <= 0) break;  // more bytes needed, or the silence ends it (Run)
      if (static_cast<std::size_t>(len) > line_.in.size()) {
        bank_.CountRejected();
        line_.have = 0;
        break;
      }
      if (line_.have < static_cast<std::size_t>(len)) break;
      if (!mb::RtuCrcValid(line_.in.data(), len)) {
        bank_.CountRejected();  // framing is lost: drop what came
        line_.have = 0;
        break;
      }
      AnswerRtu(line_.in.data(), static_cast<std::size_t>(len));
      const auto n = static_cast<std::size_t>(len);
      std::memmove(line_.in.data(), line_.in.data() + n, line_.have - n);
      line_.have -= n;
    }
  }
}

void ModbusServer::AnswerRtu(const std::uint8_t* frame, std::size_t len) {
  const std::uint8_t unit = frame[0];
  if (!bank_.Serves(unit) && unit != mb::kBroadcastUnit) {  // addressed to another unit
    bank_.CountRejected();
    return;
  }
  std::uint8_t adu[mb::kMaxRtuAdu + 2];
  const int reply_len = bank_.Answer(unit, frame + 1, static_cast<int>(len) - 3, adu + 1).reply_len;
  if (unit == mb::kBroadcastUnit) return;  // carried out, never answered
  adu[0] = unit;
  const int n = mb::PutRtuCrc(adu, 1 + reply_len);
  if (!Queue(line_, adu, static_cast<std::size_t>(n))) line_.out_len = 0;  // nobody reads
}

bool ModbusServer::Queue(Client& c, const std::uint8_t* data, std::size_t n) {
  if (c.out_len + n > c.out.size()) return false;
  std::memcpy(c.out.data() + c.out_len, data, n);
  c.out_len += n;
  Flush(c);
  return true;
}

void ModbusServer::Flush(Client& c) {
  while (c.fd >= 0 && c.out_len > 0) {
    const ssize_t n = &c == &line_ ? write(c.fd, c.out.data(), c.out_len)
                                   : send(c.fd, c.out.data(), c.out_len, MSG_NOSIGNAL);
    if (n > 0) {
      std::memmove(c.out.data(), c.out.data() + n, c.out_len - static_cast<std::size_t>(n));
      c.out_len -= static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    if (&c == &line_) {
      c.out_len = 0;
    } else {
      Drop(c, /*refused=*/false);
    }
    return;
  }
}

void ModbusServer::Drop(Client& c, bool refused) {
  if (c.fd >= 0) close(c.fd);
  c.fd = -1;
  c.have = 0;
  c.out_len = 0;
  c.request_start_ns = 0;
  if (refused) bank_.CountRefused();
}

namespace {

bool OpenTcp(ModbusServer& server, const std::string& endpoint, std::string* error) {
  const auto colon = endpoint.rfind(':');
  int port = 0;
  if (colon == std::string::npos || colon == 0) {
    *error = "modbus-tcp '" + endpoint + "': expected HOST:PORT";
    return false;
  }
  const std::string host = endpoint.substr(0, colon), digits = endpoint.substr(colon + 1);
  if (digits.empty() || digits.size() > 5 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }) ||
      (port = std::stoi(digits)) < 1 || port > 65535) {
    *error = "modbus-tcp '" + endpoint + "': port must be 1-65535";
    return false;
  }
  std::string why;
  if (!server.ListenTcp(host, port, &why)) {
    *error = "modbus-tcp '" + endpoint + "': " + why;
    return false;
  }
  return true;
}

bool OpenRtu(ModbusServer& server, const std::string& endpoint, int* master_fd, int* slave_fd,
             std::string* error) {
  char slave_name[128] = {};
  if (openpty(master_fd, slave_fd, slave_name, nullptr, nullptr) != 0) {
    *error = "modbus-rtu: openpty: " + std::string(std::strerror(errno));
    return false;
  }
  termios t{};
  if (tcgetattr(*slave_fd, &t) == 0) {
    cfmakeraw(&t);
    cfsetspeed(&t, B115200);
    tcsetattr(*slave_fd, TCSANOW, &t);
  }
  unlink(endpoint.c_str());  // a link left by an earlier run
  if (symlink(slave_name, endpoint.c_str()) != 0) {
    *error = "modbus-rtu: cannot create the link '" + endpoint + "' -> " + slave_name + ": " +
             std::strerror(errno);
    return false;
  }
  server.ServeRtu(*master_fd);
  return true;
}

}  // namespace

bool OpenModbusEndpoint(ModbusServer& server, bool rtu, const std::string& endpoint, int* master_fd,
                        int* slave_fd, std::string* error) {
  return rtu ? OpenRtu(server, endpoint, master_fd, slave_fd, error)
             : OpenTcp(server, endpoint, error);
}

}  // namespace mrd::hil
