#pragma once
// The harness's Modbus server I/O (docs/modbus_registers.md, "Server conventions"): one thread
// that owns the descriptors (a TCP listening socket and up to kMaxClients clients, or the
// master of the RTU pseudo-terminal), all non-blocking and watched with poll(), so no client
// can hold it: a request is taken in as its bytes come (per client), a reply is queued and
// sent as the client reads it. The registers are the Bank's (the port's): it answers one
// request PDU at a time and never waits on the wire.
//
// Rules (each refusal counted):
//   TCP  more than kMaxClients clients: the new one is closed at once (refused); a request
//        not complete kRequestTimeoutNs after its first byte, or replies piling up beyond
//        kMaxOutput (a client that does not read): the client is dropped (refused); an MBAP
//        protocol id other than 0: not Modbus, dropped without reply (rejected); a length
//        field that frames nothing: the stream is lost, the client dropped (rejected); unit id
//        kUnit (a profile's units: Bank::Serves), 0 or 0xFF (the Modbus TCP guide: a device
//        addressed by its IP) answered, any other unit gets exception 0x0B (rejected).
//   RTU  a frame is delimited by its function's length, or by kRtuGapNs of silence for a
//        function without one; a bad CRC or a torn frame is dropped (rejected); unit kUnit (or a
//        profile's) is answered; unit 0 is a broadcast: a write is carried out, nothing is
//        answered; other units are not answered (rejected).

#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "mrd/protocol/modbus_frame.hpp"
#include "mrd/protocol/modbus_server.hpp"

namespace mrd::hil {

class ModbusServer {
 public:
  // The registers behind the server (ModbusPort): thread-safe, never blocks for long.
  class Bank {
   public:
    // unit: the request's unit id (0: an RTU broadcast or a TCP request for unit 0; 0xFF:
    // TCP's "the device at this address").
    virtual protocol::modbus::ServerAnswer Answer(std::uint8_t unit, const std::uint8_t* pdu,
                                                  int len, std::uint8_t* reply) = 0;
    // The unit ids behind this server (besides 0, and 0xFF over TCP): kUnit unless a device
    // profile names others.
    virtual bool Serves(std::uint8_t unit) const { return unit == kUnit; }
    virtual void CountRejected() = 0;
    virtual void CountRefused() = 0;

   protected:
    ~Bank() = default;
  };

  static constexpr std::uint8_t kUnit = 1;
  static constexpr int kMaxClients = 32;
  static constexpr int kListenBacklog = 64;
  static constexpr std::int64_t kRequestTimeoutNs = 1'000'000'000;
  static constexpr std::size_t kMaxOutput = 4096;
  static constexpr std::int64_t kRtuGapNs = 5'000'000;

  explicit ModbusServer(Bank& bank) : bank_(bank) {}
  ~ModbusServer() { Stop(); }
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  // TCP: listens on host (IPv4 dotted) : port. false: *error.
  bool ListenTcp(const std::string& host, int port, std::string* error);
  // RTU: serves on the master of a pseudo-terminal (the fd stays the caller's).
  void ServeRtu(int master_fd);
  void Start();
  void Stop();

 private:
  struct Client {
    int fd = -1;
    std::array<std::uint8_t, protocol::modbus::kMaxTcpAdu> in{};
    std::size_t have = 0;
    std::int64_t request_start_ns = 0;  // first byte of the request in `in` (0: none)
    std::array<std::uint8_t, kMaxOutput> out{};
    std::size_t out_len = 0;
  };

  void Run();
  void Accept(std::int64_t now);
  void ReadTcp(Client& c, std::int64_t now);
  void AnswerTcp(Client& c, const std::uint8_t* frame);
  void ReadRtu(std::int64_t now);
  void AnswerRtu(const std::uint8_t* frame, std::size_t len);
  // Appends to c's output (false: no room) and sends what the socket takes.
  bool Queue(Client& c, const std::uint8_t* data, std::size_t n);
  void Flush(Client& c);
  void Drop(Client& c, bool refused);

  Bank& bank_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  int listen_fd_ = -1;
  std::int64_t accept_paused_until_ = 0;  // out of descriptors: accept again later
  std::vector<Client> clients_;           // kMaxClients slots, fd -1 when free
  // RTU
  Client line_;  // the pty master's input, output and (fd) descriptor
  std::int64_t last_byte_ns_ = 0;
};

// Opens the server's endpoint: TCP "HOST:PORT" (listens), or RTU: a pseudo-terminal whose
// slave the link `endpoint` points to (*master_fd, *slave_fd: the caller's to close, and the
// link to unlink). false: *error.
bool OpenModbusEndpoint(ModbusServer& server, bool rtu, const std::string& endpoint, int* master_fd,
                        int* slave_fd, std::string* error);

}  // namespace mrd::hil
