#pragma once
// A Modbus TCP server for the client's fault tests, framed here by hand from the Modbus TCP
// guide (MBAP: transaction, protocol 0, length, unit; then the PDU), not with the project's
// codec: it answers 0x03 with a sensor block whose seq (and velocity, seq x 1e-4 cm/s) grows
// with every read and records when each read arrived; 0x10 is acknowledged. Scripted
// misbehaviour: answer late, trickle the reply a byte at a time, set the faults register,
// answer with another unit id or protocol id, never answer, or reset every connection at once.

#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <mutex>
#include <thread>
#include <vector>

#include "mrd/common/clock.hpp"

namespace mrd::test {

struct RawPeerScript {
  int reply_delay_ms = 0;        // each reply sent this long after its request
  int trickle_ms = 0;            // > 0: each reply byte sent alone, this long after the previous
  std::uint16_t faults = 0;      // the sensor block's faults register (12)
  int reply_unit = -1;           // >= 0: every reply carries this unit id
  int reply_protocol = 0;        // every reply's MBAP protocol id
  bool silent = false;           // requests are read, never answered
  bool reset_on_accept = false;  // every connection reset as soon as it is accepted
};

class RawTcpPeer {
 public:
  RawTcpPeer(int port, RawPeerScript script) : script_(script) {
    listen_ = socket(AF_INET, SOCK_STREAM, 0);
    const int one = 1;
    setsockopt(listen_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    if (bind(listen_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || listen(listen_, 16) != 0) {
      close(listen_);
      listen_ = -1;
      return;
    }
    thread_ = std::thread([this] { Run(); });
  }
  ~RawTcpPeer() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
    if (client_ >= 0) close(client_);
    if (listen_ >= 0) close(listen_);
  }
  bool listening() const { return listen_ >= 0; }
  int accepts() const { return accepts_.load(); }
  int reads() const { return reads_.load(); }
  int requests() const { return requests_.load(); }
  // CLOCK_MONOTONIC [ns] when the read that served `seq` arrived (0: unknown).
  std::int64_t ReadArrival(std::uint32_t seq) const {
    std::lock_guard<std::mutex> lock(mu_);
    return seq >= 1 && seq <= arrivals_.size() ? arrivals_[seq - 1] : 0;
  }

  static std::int64_t NowNs() { return common::MonotonicNs(); }

 private:
  void Run() {
    std::vector<std::uint8_t> in;
    while (running_) {
      pollfd p[2] = {{listen_, POLLIN, 0}, {client_, POLLIN, 0}};
      if (poll(p, client_ >= 0 ? 2 : 1, 10) <= 0) continue;
      if ((p[0].revents & POLLIN) != 0) {
        const int fd = accept(listen_, nullptr, nullptr);
        if (fd >= 0) {
          ++accepts_;
          if (script_.reset_on_accept) {
            const linger l{1, 0};  // close with RST
            setsockopt(fd, SOL_SOCKET, SO_LINGER, &l, sizeof l);
            close(fd);
          } else {
            if (client_ >= 0) close(client_);  // the client reconnected
            client_ = fd;
            in.clear();
          }
        }
        continue;
      }
      if (client_ < 0 || (p[1].revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
      std::uint8_t buf[512];
      const ssize_t n = read(client_, buf, sizeof buf);
      if (n <= 0) {
        close(client_);
        client_ = -1;
        continue;
      }
      in.insert(in.end(), buf, buf + n);
      while (in.size() >= 7) {  // MBAP: length (bytes 4-5) counts the unit id and the PDU
        const std::size_t len = 6 + static_cast<std::size_t>((in[4] << 8) | in[5]);
        if (in.size() < len) break;
        std::vector<std::uint8_t> req(in.begin(), in.begin() + static_cast<std::ptrdiff_t>(len));
        in.erase(in.begin(), in.begin() + static_cast<std::ptrdiff_t>(len));
        Answer(req);
      }
    }
  }

  void Answer(const std::vector<std::uint8_t>& req) {
    ++requests_;
    std::vector<std::uint8_t> pdu;
    const std::uint8_t function = req[7];
    if (function == 0x03) {
      const int count = (req[10] << 8) | req[11];
      const auto seq = static_cast<std::uint32_t>(++reads_);
      {
        std::lock_guard<std::mutex> lock(mu_);
        arrivals_.push_back(NowNs());
      }
      std::vector<std::uint16_t> regs(static_cast<std::size_t>(count), 0);
      if (count >= 13) {
        regs[0] = static_cast<std::uint16_t>(seq >> 16);  // seq, high word first
        regs[1] = static_cast<std::uint16_t>(seq & 0xFFFF);
        regs[2] = static_cast<std::uint16_t>(seq >> 16);  // velocity = seq x 1e-4 cm/s
        regs[3] = static_cast<std::uint16_t>(seq & 0xFFFF);
        regs[12] = script_.faults;
      }
      pdu = {0x03, static_cast<std::uint8_t>(2 * count)};
      for (std::uint16_t r : regs) {
        pdu.push_back(static_cast<std::uint8_t>(r >> 8));
        pdu.push_back(static_cast<std::uint8_t>(r & 0xFF));
      }
    } else if (function == 0x10) {
      pdu.assign(req.begin() + 7, req.begin() + 12);  // function, address, count
    } else {
      pdu = {static_cast<std::uint8_t>(function | 0x80), 0x01};
    }
    if (script_.silent) return;
    std::vector<std::uint8_t> rsp = {
        req[0],
        req[1],
        static_cast<std::uint8_t>(script_.reply_protocol >> 8),
        static_cast<std::uint8_t>(script_.reply_protocol & 0xFF),
        static_cast<std::uint8_t>((pdu.size() + 1) >> 8),
        static_cast<std::uint8_t>((pdu.size() + 1) & 0xFF),
        script_.reply_unit >= 0 ? static_cast<std::uint8_t>(script_.reply_unit) : req[6]};
    rsp.insert(rsp.end(), pdu.begin(), pdu.end());
    if (script_.reply_delay_ms > 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(script_.reply_delay_ms));
    }
    if (script_.trickle_ms > 0) {
      for (std::uint8_t byte : rsp) {
        if (!running_ || send(client_, &byte, 1, MSG_NOSIGNAL) != 1) return;
        std::this_thread::sleep_for(std::chrono::milliseconds(script_.trickle_ms));
      }
      return;
    }
    (void)!send(client_, rsp.data(), rsp.size(), MSG_NOSIGNAL);
  }

  RawPeerScript script_;
  int listen_ = -1;
  int client_ = -1;
  std::atomic<bool> running_{true};
  std::atomic<int> accepts_{0}, reads_{0}, requests_{0};
  mutable std::mutex mu_;
  std::vector<std::int64_t> arrivals_;
  std::thread thread_;
};

}  // namespace mrd::test
