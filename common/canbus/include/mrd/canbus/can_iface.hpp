#pragma once
// A CAN interface on any fd carrying `struct can_frame` (socket.hpp), in the spirit of
// ArduPilot's AP_HAL::CANIface: opened on an fd at start-up, non-blocking receive with a
// stamp, send with a deadline (a frame still queued when its deadline passes is dropped, never
// sent late), bus statistics. Real-time safe: no allocation, no blocking, bounded work (one
// frame per Receive; at most kTxQueue frames per Flush). Single-threaded.
//
// Receive stamps are CLOCK_MONOTONIC [ns] at the read (the loop's clock). On SocketCAN an
// error frame reporting bus-off comes back as kBusOff.

#include <linux/can.h>

#include <array>
#include <cstddef>
#include <cstdint>

namespace mrd::canbus {

enum class CanResult : std::uint8_t {
  kOk = 0,
  kEmpty,         // nothing to receive
  kDisconnected,  // peer or relay gone (EOF, reset, network down), or no fd
  kBusOff,        // controller bus-off (SocketCAN error frame)
  kBadFrame,      // a packet that is not one can_frame (wrong size): dropped
  kOverflow,      // transmit queue full: the new frame is dropped
  kTimedOut,      // queued frame(s) dropped at their deadline
  kError,         // other errno
};
const char* CanResultName(CanResult result);

struct CanStats {
  std::uint64_t rx_frames = 0;
  std::uint64_t rx_bad = 0;       // wrong-size packets
  std::uint64_t rx_errors = 0;    // error frames and failed reads
  std::uint64_t tx_frames = 0;    // written to the fd
  std::uint64_t tx_timedout = 0;  // dropped at their deadline
  std::uint64_t tx_overflow = 0;  // refused: queue full
  std::uint64_t tx_errors = 0;
  std::uint64_t bus_off = 0;
  std::uint64_t disconnects = 0;
};

std::int64_t MonotonicNs();

class CanIface {
 public:
  static constexpr std::size_t kTxQueue = 8;

  CanIface() = default;
  ~CanIface() { Close(); }
  CanIface(const CanIface&) = delete;
  CanIface& operator=(const CanIface&) = delete;

  // Takes ownership of fd (made non-blocking); drops what was queued for the old one.
  void Attach(int fd);
  void Close();
  bool is_open() const { return fd_ >= 0; }
  int fd() const { return fd_; }

  // One frame if one is waiting.
  CanResult Receive(can_frame* frame, std::int64_t* stamp_ns);
  // Queues frame until deadline_ns and sends what the fd takes now (Flush).
  CanResult Send(const can_frame& frame, std::int64_t deadline_ns, std::int64_t now_ns);
  // Writes queued frames in order until the fd would block; drops those past their deadline.
  // kOk, kTimedOut (something dropped), kDisconnected or kError.
  CanResult Flush(std::int64_t now_ns);

  std::size_t pending() const { return count_; }
  const CanStats& stats() const { return stats_; }

 private:
  struct Slot {
    can_frame frame;
    std::int64_t deadline_ns;
  };
  CanResult Lost();

  int fd_ = -1;
  std::array<Slot, kTxQueue> queue_{};
  std::size_t head_ = 0, count_ = 0;
  CanStats stats_;
};

}  // namespace mrd::canbus
