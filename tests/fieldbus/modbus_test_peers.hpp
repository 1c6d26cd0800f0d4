#pragma once
// Scripted Modbus peers for the device tests: a libmodbus TCP server on 127.0.0.1 that
// answers from a register map, answers every request with an exception, or never answers;
// and an RTU peer on a pseudo-terminal that answers with a corrupted CRC or once too late.

#include <modbus/modbus.h>
#include <netinet/in.h>
#include <pty.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "mrd/protocol/modbus_map.hpp"

namespace mrd::test {

// Polls done() every millisecond until it holds (true) or timeout_s has passed (false).
inline bool WaitFor(const std::function<bool()>& done, double timeout_s = 3.0) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

// 127.0.0.1:port (0: any free port, for bind).
inline sockaddr_in Loopback(int port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  return a;
}

// A TCP port on 127.0.0.1 that is free now and that the kernel never hands out as a source
// port: below the ephemeral range (/proc/sys/net/ipv4/ip_local_port_range), so a connection
// another test opens before the caller's server binds cannot take it. Candidates start at a
// place set by the process id and a per-process count, so tests that ctest runs side by side
// (each its own process) probe far apart; a port still in use or in TIME_WAIT is skipped.
inline int FreeTcpPort() {
  int ephemeral_lo = 32768;
  if (FILE* f = std::fopen("/proc/sys/net/ipv4/ip_local_port_range", "r")) {
    if (std::fscanf(f, "%d", &ephemeral_lo) != 1) ephemeral_lo = 32768;
    std::fclose(f);
  }
  constexpr unsigned kFirst = 10000;
  const unsigned span = ephemeral_lo > static_cast<int>(kFirst) + 100
                            ? static_cast<unsigned>(ephemeral_lo) - kFirst
                            : 0U;
  static std::atomic<unsigned> calls{0};
  const unsigned start = static_cast<unsigned>(getpid()) * 7919U + calls.fetch_add(1) * 104729U;
  for (unsigned i = 0; i < span; ++i) {
    const int port = static_cast<int>(kFirst + (start + i) % span);
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    const sockaddr_in a = Loopback(port);
    const bool free = bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) == 0;
    close(fd);
    if (free) return port;
  }
  // No range below the ephemeral one: a port the kernel picks (free a moment ago).
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a = Loopback(0);
  bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  close(fd);
  return ntohs(a.sin_port);
}

// A blocking TCP client connected to 127.0.0.1:port, or -1. send_timeout_s > 0 bounds
// connect() and every send (SO_SNDTIMEO; 0: unbounded, the socket's default).
inline int ConnectLoopback(int port, int send_timeout_s = 0) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  const sockaddr_in a = Loopback(port);
  if (send_timeout_s > 0) {
    const timeval tv{send_timeout_s, 0};
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  }
  if (connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

enum class PeerBehaviour { kAnswer, kException, kSilent };

class ScriptedTcpServer {
 public:
  ScriptedTcpServer(int port, PeerBehaviour behaviour) : behaviour_(behaviour) {
    ctx_ = modbus_new_tcp("127.0.0.1", port);
    mapping_ = modbus_mapping_new(0, 0, protocol::modbus::kMapSize, 0);
    listen_fd_ = modbus_tcp_listen(ctx_, 2);
    thread_ = std::thread([this] { Run(); });
  }
  ~ScriptedTcpServer() {
    running_ = false;
    thread_.join();
    for (int fd : clients_) close(fd);
    if (listen_fd_ >= 0) close(listen_fd_);
    modbus_mapping_free(mapping_);
    modbus_free(ctx_);
  }
  bool listening() const { return listen_fd_ >= 0; }
  void SetRegister(int addr, std::uint16_t v) {
    std::lock_guard<std::mutex> lock(mu_);
    mapping_->tab_registers[addr] = v;
  }
  std::uint16_t Register(int addr) {
    std::lock_guard<std::mutex> lock(mu_);
    return mapping_->tab_registers[addr];
  }
  int requests() const { return requests_.load(); }

 private:
  void Run() {
    std::uint8_t q[MODBUS_TCP_MAX_ADU_LENGTH];
    while (running_) {
      fd_set fds;
      FD_ZERO(&fds);
      FD_SET(listen_fd_, &fds);
      int max_fd = listen_fd_;
      for (int fd : clients_) {
        FD_SET(fd, &fds);
        max_fd = fd > max_fd ? fd : max_fd;
      }
      timeval tv{0, 20'000};
      if (select(max_fd + 1, &fds, nullptr, nullptr, &tv) <= 0) continue;
      if (FD_ISSET(listen_fd_, &fds)) {
        int l = listen_fd_;
        const int fd = modbus_tcp_accept(ctx_, &l);
        if (fd >= 0) clients_.push_back(fd);
      }
      for (std::size_t i = 0; i < clients_.size();) {
        const int fd = clients_[i];
        if (!FD_ISSET(fd, &fds)) {
          ++i;
          continue;
        }
        modbus_set_socket(ctx_, fd);
        const int n = modbus_receive(ctx_, q);
        if (n < 0) {
          close(fd);
          clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(i));
          continue;
        }
        ++requests_;
        if (behaviour_ == PeerBehaviour::kAnswer) {
          std::lock_guard<std::mutex> lock(mu_);
          modbus_reply(ctx_, q, n, mapping_);
        } else if (behaviour_ == PeerBehaviour::kException) {
          modbus_reply_exception(ctx_, q, MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE);
        }
        ++i;
      }
    }
  }

  PeerBehaviour behaviour_;
  modbus_t* ctx_ = nullptr;
  modbus_mapping_t* mapping_ = nullptr;
  int listen_fd_ = -1;
  std::vector<int> clients_;
  std::mutex mu_;
  std::atomic<bool> running_{true};
  std::atomic<int> requests_{0};
  std::thread thread_;
};

// Modbus RTU CRC-16 (polynomial 0xA001, initial 0xFFFF), low byte first on the wire.
inline std::uint16_t Crc16(const std::uint8_t* p, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ p[i]);
    for (int b = 0; b < 8; ++b) {
      crc = (crc & 1U) != 0 ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001U)
                            : static_cast<std::uint16_t>(crc >> 1);
    }
  }
  return crc;
}

// An RTU peer on a pty (link path = the slave). Reads get a sensor block whose sequence
// number grows with every answer; writes are acknowledged (address and count echoed).
// kBadCrc: every answer has its CRC's bits flipped. kLateOnce: answer number late_index
// (from 0) is sent late_ms after its request (past the master's response timeout), the
// others at once.
enum class RtuScript { kBadCrc, kLateOnce };

class ScriptedRtuPeer {
 public:
  ScriptedRtuPeer(std::string link, RtuScript script, int late_index = 0, int late_ms = 0)
      : link_(std::move(link)), script_(script), late_index_(late_index), late_ms_(late_ms) {
    char name[128] = {};
    openpty(&master_, &slave_, name, nullptr, nullptr);
    termios t{};
    tcgetattr(slave_, &t);
    cfmakeraw(&t);
    tcsetattr(slave_, TCSANOW, &t);
    unlink(link_.c_str());
    symlink(name, link_.c_str());
    thread_ = std::thread([this] { Run(); });
  }
  ~ScriptedRtuPeer() {
    running_ = false;
    thread_.join();
    close(master_);
    close(slave_);
    unlink(link_.c_str());
  }
  int answers() const { return answers_.load(); }

 private:
  void Run() {
    while (running_) {
      fd_set fds;
      FD_ZERO(&fds);
      FD_SET(master_, &fds);
      timeval tv{0, 20'000};
      if (select(master_ + 1, &fds, nullptr, nullptr, &tv) <= 0) continue;
      usleep(2000);  // let the whole request arrive
      std::uint8_t req[300];
      const ssize_t n = read(master_, req, sizeof req);
      if (n < 8) continue;
      std::vector<std::uint8_t> rsp = {req[0], req[1]};
      if (req[1] == 0x03) {
        const int count = (req[4] << 8) | req[5];
        rsp.push_back(static_cast<std::uint8_t>(2 * count));
        rsp.resize(rsp.size() + static_cast<std::size_t>(2 * count), 0);
        const std::size_t lo = 3 + 2 * (protocol::modbus::kSeq + 1);  // low word of the seq
        const int seq = answers_.load() + 1;
        if (rsp.size() >= lo + 2) {
          rsp.at(lo) = static_cast<std::uint8_t>(seq >> 8);
          rsp.at(lo + 1) = static_cast<std::uint8_t>(seq & 0xFF);
        }
      } else {  // 0x10 echo of address and count
        rsp.insert(rsp.end(), req + 2, req + 6);
      }
      std::uint16_t crc = Crc16(rsp.data(), rsp.size());
      if (script_ == RtuScript::kBadCrc) crc = static_cast<std::uint16_t>(crc ^ 0xFFFFU);
      rsp.push_back(static_cast<std::uint8_t>(crc & 0xFF));
      rsp.push_back(static_cast<std::uint8_t>(crc >> 8));
      if (script_ == RtuScript::kLateOnce && answers_.load() == late_index_) {
        usleep(static_cast<useconds_t>(late_ms_) * 1000U);
      }
      if (write(master_, rsp.data(), rsp.size()) > 0) ++answers_;
    }
  }

  std::string link_;
  RtuScript script_;
  int late_index_, late_ms_;
  int master_ = -1, slave_ = -1;
  std::atomic<bool> running_{true};
  std::atomic<int> answers_{0};
  std::thread thread_;
};

}  // namespace mrd::test
