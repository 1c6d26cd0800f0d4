#pragma once
// One Modbus client link (TCP or RTU) and its transactions, for ModbusDevice's worker thread.
// libmodbus opens and configures the link (the TCP connection with its connect timeout, the
// serial line's termios); the requests and replies are framed here (modbus_frame.hpp) on the
// link's non-blocking descriptor, because libmodbus 3.1.6 does not check a TCP reply's unit
// id, accepts a non-zero MBAP protocol id (it tests `hi != 0 && lo != 0`), bounds only the
// first byte and each gap (a reply trickled a byte per 15 ms takes as long as it likes), and
// cannot be interrupted by a stop request or a newer command.
//
// A transaction: the request is sent, then its reply must be complete by one deadline:
// response_timeout after the request was sent (RTU: plus the request's and the reply's time
// on the wire at the configured baud rate). TCP replies are matched by transaction id: one
// with another id (a reply that came after its timeout, or to an abandoned request) is read
// and dropped, and the wait goes on. RTU has no transaction id: input is discarded before
// every request, a frame from the unit that answers another function is dropped (a late
// reply), and the caller waits for a quiet line after a failure (Quiet).
// Every wait also watches a wake-up descriptor (eventfd): when it fires, the caller's
// Interrupt decides whether the wait is abandoned.

#include <sys/socket.h>

#include <cstdint>
#include <string>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/io/io_config.hpp"
#include "mrd/protocol/modbus_frame.hpp"

typedef struct _modbus modbus_t;  // NOLINT: libmodbus's own name

namespace mrd::firmware {

class ModbusLink {
 public:
  // What a wait was doing when the wake-up descriptor fired.
  enum class Phase : std::uint8_t {
    kReply,     // waiting for a reply, none of its bytes read yet
    kMidFrame,  // sending a request or reading a reply frame (TCP: abandoning it loses the
                // stream's framing, so the link is then broken)
    kQuiet,     // RTU: waiting for a quiet line after a failure
  };
  class Interrupt {
   public:
    // true abandons the wait.
    virtual bool Abandon(Phase phase) = 0;

   protected:
    ~Interrupt() = default;
  };

  enum class Result : std::uint8_t {
    kOk,
    kFailed,     // *why says why (counted by the caller)
    kAbandoned,  // Interrupt::Abandon said so; the request may still be answered later
  };

  explicit ModbusLink(const ModbusConfig& config)
      : config_(config), unit_(static_cast<std::uint8_t>(config.slave)) {}
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  // Creates the libmodbus context (no connection yet). false: *error.
  bool Create(std::string* error);
  // Connects (TCP, bounded by the response timeout) or opens the serial line. false: errno.
  // TCP: the host is resolved once, the first time it resolves (getaddrinfo allocates); every
  // later connect, the worker's reconnects included, reuses those addresses and allocates
  // nothing.
  bool Open();
  void Close();
  bool open() const { return fd_ >= 0; }
  // The link is down or its byte stream is out of step (EOF, reset, I/O error, a TCP frame
  // whose length field frames nothing, a TCP frame abandoned half read): only a reconnect
  // helps.
  bool broken() const { return broken_; }

  // Sends `pdu` and waits for its reply PDU (copied to reply, *reply_len bytes; room for
  // kMaxPdu). kFailed: *why is kTimeout, kDisconnected, kRejectedFrame (wrong unit id or
  // protocol id, a frame of unknown length) or kCrc; the reply's content is the caller's to
  // check. wake_fd < 0: no wake-ups.
  Result Transact(const std::uint8_t* pdu, int len, std::uint8_t* reply, int* reply_len,
                  IoError* why, int wake_fd, Interrupt* interrupt);
  // The unit id of the following transactions (a device profile talks to several units on
  // one link; default: config.slave).
  void set_unit(std::uint8_t unit) { unit_ = unit; }
  std::uint8_t unit() const { return unit_; }
  // RTU: discards input until nothing has arrived for one response timeout (at most
  // kMaxQuietRounds waits). false when a wake-up abandoned it.
  bool Quiet(int wake_fd, Interrupt* interrupt);

  static constexpr int kMaxQuietRounds = 4;

 private:
  enum class Wait : std::uint8_t { kReady, kTimeout, kAbandoned, kHangUp };
  Wait WaitFor(short events, std::int64_t deadline_ns, Phase phase, int wake_fd,
               Interrupt* interrupt);
  Result Send(const std::uint8_t* adu, int len, std::int64_t deadline_ns, IoError* why, int wake_fd,
              Interrupt* interrupt);
  // Reads exactly n bytes into buf by the deadline (phase: of the first byte).
  Result ReadExactly(std::uint8_t* buf, int n, std::int64_t deadline_ns, Phase phase, IoError* why,
                     int wake_fd, Interrupt* interrupt);
  Result ReceiveTcp(std::uint8_t* reply, int* reply_len, std::int64_t deadline_ns, IoError* why,
                    int wake_fd, Interrupt* interrupt);
  Result ReceiveRtu(std::uint8_t function, std::uint8_t* reply, int* reply_len,
                    std::int64_t deadline_ns, IoError* why, int wake_fd, Interrupt* interrupt);
  Result Broken(IoError e, IoError* why);
  // A send or read whose wait ended other than ready (w): a hang-up breaks the link; a timeout
  // (*why) or an abandoned wait breaks it too when mid_frame (part of a frame is on the stream).
  Result Unfinished(Wait w, bool mid_frame, IoError* why);
  std::int64_t WireNs(int bytes) const;
  // TCP: resolves the host into addrs_ (once; false and errno when it does not resolve).
  bool Resolve();
  // TCP: a connection to addrs_[i] within the response timeout; the descriptor or -1 (errno).
  int ConnectTo(int i) const;

  static constexpr int kMaxAddrs = 4;
  struct Addr {
    sockaddr_storage addr;
    socklen_t len;
  };

  ModbusConfig config_;
  Addr addrs_[kMaxAddrs] = {};
  int addr_count_ = 0;
  modbus_t* ctx_ = nullptr;
  int fd_ = -1;
  bool broken_ = false;
  std::uint16_t transaction_ = 0;
  std::uint8_t unit_ = 1;
  std::uint8_t buf_[protocol::modbus::kMaxTcpAdu + 8] = {};
};

}  // namespace mrd::firmware
