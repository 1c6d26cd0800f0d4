#pragma once
// A CAN interface on any fd carrying `struct can_frame` (socket.hpp), in the spirit of
// ArduPilot's AP_HAL::CANIface: opened on an fd at start-up, non-blocking receive with a
// stamp, send with a deadline (a frame still queued when its deadline passes is dropped, never
// sent late), bus statistics. Real-time safe: no allocation, no blocking, bounded work (one
// recvmmsg of at most kRxBatch packets per Receive that finds none read ahead; at most kTxQueue
// frames per Flush, written with sendmmsg). Single-threaded.
//
// System calls are the cost of a lockstep period (each is several microseconds on a virtual
// machine), so both directions batch: Receive reads what is waiting in one call and hands it
// out frame by frame (order, stamps and errors as one read per frame would give them), and
// between Hold and Release Send only queues, so a period's frames leave in one call and wake
// their reader once.
//
// Receive stamps are CLOCK_MONOTONIC [ns] of the frame's arrival, not of the read, so a frame
// that waited in the socket (a stalled reader, a backlog behind a flood) shows its true age:
//   local frame bus  the relay's stamp carried in the packet (LocalBusPacket: when the frame
//                    entered the bus, i.e. when its sender wrote it)
//   SocketCAN        the kernel's receive stamp (SO_TIMESTAMPNS, enabled by Attach)
// Kernel stamps are CLOCK_REALTIME; each is converted with the two clocks read together at the
// read (ArrivalStamp): the age is then exact unless the wall clock is stepped between arrival
// and read (NTP slewing moves both clocks alike). A stamp from the future (the wall clock
// stepped back meanwhile) has an unknown age and is taken as kUnknownAgeNs old: stale, never
// fresh. A packet without any stamp (a peer without timestamps) is stamped at the read.
// On SocketCAN an error frame reporting bus-off comes back as kBusOff.

#include <linux/can.h>
#include <sys/types.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <ctime>

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

// What the local bus relay hands a node (local_bus.hpp): the frame and the CLOCK_MONOTONIC
// time [ns] it entered the bus. Nodes send bare `struct can_frame`s (16 bytes).
struct LocalBusPacket {
  can_frame frame;
  std::int64_t stamp_ns;
};
static_assert(sizeof(LocalBusPacket) == 24, "local bus packet: 16-byte frame + 8-byte stamp");

// Age given to a kernel stamp from the future (see above) [ns].
inline constexpr std::int64_t kUnknownAgeNs = 1'000'000'000;
// A kernel receive stamp (CLOCK_REALTIME) as CLOCK_MONOTONIC, given both clocks read now.
std::int64_t ArrivalStamp(const timespec& realtime_stamp, std::int64_t monotonic_now_ns,
                          std::int64_t realtime_now_ns);
// Turns on kernel receive stamps (SO_TIMESTAMPNS) on a socket; false where unsupported.
bool EnableReceiveStamps(int fd);
// recvmsg of one packet with its kernel stamp: bytes (or -1 with errno); *stamp_ns the
// arrival as CLOCK_MONOTONIC, or the read time when the packet has no kernel stamp; *truncated
// when the packet was longer than size.
ssize_t ReceiveStamped(int fd, void* buf, std::size_t size, std::int64_t* stamp_ns,
                       bool* truncated);
// One packet of ReceiveStampedBatch: its bytes (room for a CAN FD frame, so an oversized packet
// shows as such), their count, its stamp (as ReceiveStamped's) and whether it was longer.
struct StampedPacket {
  alignas(LocalBusPacket) unsigned char data[sizeof(canfd_frame)];
  std::size_t size;
  std::int64_t stamp_ns;
  bool truncated;
};
inline constexpr std::size_t kMaxStampedBatch = 16;
// recvmmsg of up to count (at most kMaxStampedBatch) waiting packets, each stamped as by
// ReceiveStamped: how many (a packet of size 0 is the peer's EOF), or -1 with errno when none
// could be read (EAGAIN: none waiting). Never blocks.
int ReceiveStampedBatch(int fd, StampedPacket* packets, std::size_t count);

class CanIface {
 public:
  static constexpr std::size_t kTxQueue = 8;
  static constexpr std::size_t kRxBatch = 8;  // packets read ahead by one Receive

  CanIface() = default;
  ~CanIface() { Close(); }
  CanIface(const CanIface&) = delete;
  CanIface& operator=(const CanIface&) = delete;

  // Takes ownership of fd (made non-blocking, kernel receive stamps on); drops what was queued
  // for the old one.
  void Attach(int fd);
  void Close();
  bool is_open() const { return fd_ >= 0; }
  int fd() const { return fd_; }

  // One frame if one is waiting (read ahead, or from the fd), with its arrival stamp.
  CanResult Receive(can_frame* frame, std::int64_t* stamp_ns);
  // Whether something waits to be received (read ahead, or a zero-timeout poll).
  bool Readable() const;
  // Frames read ahead (Receive returns them without a system call; a wait on fd() would not
  // see them).
  std::size_t buffered() const { return rx_count_ - rx_head_; }
  // Queues frame until deadline_ns and sends what the fd takes now (Flush); while held, only
  // queues (a full queue is flushed at once).
  CanResult Send(const can_frame& frame, std::int64_t deadline_ns, std::int64_t now_ns);
  // Holds Send's frames in the queue until Release, which flushes them in one system call
  // (Flush's result). Close and Flush end nothing: Flush writes held frames too.
  void Hold() { held_ = true; }
  CanResult Release(std::int64_t now_ns) {
    held_ = false;
    return Flush(now_ns);
  }
  bool held() const { return held_; }
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
  CanResult Take(const StampedPacket& p, can_frame* frame, std::int64_t* stamp_ns);

  int fd_ = -1;
  std::array<Slot, kTxQueue> queue_{};
  std::size_t head_ = 0, count_ = 0;
  bool held_ = false;
  std::array<StampedPacket, kRxBatch> rx_{};  // read ahead: rx_[rx_head_, rx_count_)
  std::size_t rx_head_ = 0, rx_count_ = 0;
  CanStats stats_;
};

}  // namespace mrd::canbus
