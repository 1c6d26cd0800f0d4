#pragma once
// The local frame bus: a CAN bus stand-in for machines without AF_CAN. A relay listens on a
// UNIX SOCK_SEQPACKET socket; every node (OpenLocalBusNode) sends one `struct can_frame` per
// packet, and the relay hands each frame to every other node, as on a CAN bus (a node does not
// hear its own frames, like CAN_RAW without CAN_RAW_RECV_OWN_MSGS), as a LocalBusPacket
// (can_iface.hpp): the frame and the CLOCK_MONOTONIC time it entered the bus, i.e. the kernel's
// receive stamp of the sender's packet at the relay (SO_TIMESTAMPNS; the relay's clock where
// there is none), so a frame's age does not depend on when the relay or the node got round to
// it. Packets of another size are dropped and counted. A node whose receive buffer is full
// loses the frame (counted), as a CAN controller with a full FIFO does; the relay never blocks
// on a slow node.
//
// Robustness: the "already served?" probe of Open never blocks (a relay that is alive but does
// not accept, e.g. stopped with a full backlog, counts as serving after a bounded wait); out of
// file descriptors (EMFILE, ENFILE), the relay takes a pending connection with a spare
// descriptor and closes it at once (the node sees EOF: refused, counted), so the listener does
// not stay readable and the relay does not spin.
//
// Run it as its own process (mrd-canbus --socket PATH) or in-process on a thread (the HIL's
// CAN port does when the socket does not exist yet). Not real-time: it allocates as nodes come.

#include <poll.h>

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "mrd/canbus/can_iface.hpp"

namespace mrd::canbus {

struct RelayStats {
  std::uint64_t nodes_joined = 0;
  std::uint64_t nodes_left = 0;
  std::uint64_t frames_in = 0;
  std::uint64_t frames_out = 0;      // deliveries (frames_in x other nodes, minus drops)
  std::uint64_t frames_dropped = 0;  // deliveries lost to a full node
  std::uint64_t bad_packets = 0;     // not one can_frame
  std::uint64_t nodes_refused = 0;   // connections closed at once: out of file descriptors
};

class LocalBusRelay {
 public:
  LocalBusRelay() = default;
  ~LocalBusRelay() { Close(); }
  LocalBusRelay(const LocalBusRelay&) = delete;
  LocalBusRelay& operator=(const LocalBusRelay&) = delete;

  // Listens on path. A socket file left by a dead relay (nobody accepts) is replaced; a live
  // one is refused ("already served"). false with *error.
  bool Open(const std::string& path, std::string* error);
  // One round: waits up to timeout_ms for activity, accepts nodes, forwards frames. True when
  // something happened (a frame, a node joining or leaving), false on a timeout.
  bool Step(int timeout_ms);
  // Steps until stop is set.
  void Run(const std::atomic<bool>& stop);
  // Closes every node and the listener, removes the socket file. Idempotent.
  void Close();

  std::size_t nodes() const { return nodes_.size(); }

  // An in-process node (the HIL harness, which owns the relay): Broadcast hands a frame to every
  // socket node (stamped now); the tap receives every frame a socket node sends, with its bus
  // stamp (from Step, on the calling thread). Saves the harness's own socket round trip per
  // frame.
  void Broadcast(const void* frame);
  // Batching of the in-process node's frames: between Hold() and Release() Broadcast queues
  // its frames (logged at once, stamped when queued) and Release hands them to each socket node
  // in one sendmmsg, so a node asleep on its socket wakes once for a step's frames instead of
  // once per frame. A full queue (kHeldFrames) and Step hand the queue on at once. What each
  // node receives, in what order and with what stamps, is the same as without batching.
  // 32: a tick of four vehicle corners (two sensor frames, a drive heartbeat and a drive
  // status each) and the grant fit one batch.
  static constexpr std::size_t kHeldFrames = 32;
  void Hold() { held_ = true; }
  void Release() {
    Flush();
    held_ = false;
  }
  using Tap = void (*)(void* context, const void* frame, std::int64_t stamp_ns);
  void SetTap(Tap tap, void* context) {
    tap_ = tap;
    tap_context_ = context;
  }
  // A bus log: called with every frame that enters the bus (from a socket node, or from the
  // in-process node: in_process true), before it is handed on; on the relay's thread.
  using Log = void (*)(void* context, const void* frame, bool in_process);
  void SetLog(Log log, void* context) {
    log_ = log;
    log_context_ = context;
  }
  // Safe to call from another thread while Run is going (each field is read atomically).
  RelayStats stats() const;

 private:
  void Forward(std::size_t from, const void* frame, std::int64_t stamp_ns);
  void Flush();  // the held frames to every socket node
  void Drop(std::size_t i);
  void Accept();

  std::string path_;
  Tap tap_ = nullptr;
  void* tap_context_ = nullptr;
  Log log_ = nullptr;
  void* log_context_ = nullptr;
  int listen_fd_ = -1;
  int spare_fd_ = -1;  // given up to take a connection when out of descriptors
  std::int64_t listen_paused_until_ns_ = 0;  // accept() failing otherwise: listener not polled
  std::vector<int> nodes_;
  bool held_ = false;
  std::size_t held_count_ = 0;
  LocalBusPacket held_packets_[kHeldFrames] = {};
  // Step's scratch (kept: no allocation per round once the node count is steady).
  std::vector<pollfd> fds_;
  std::vector<char> gone_;
  static constexpr std::size_t kRxBatch = 16;  // packets per recvmmsg
  StampedPacket rx_[kRxBatch] = {};
  std::atomic<std::uint64_t> joined_{0}, left_{0}, in_{0}, out_{0}, dropped_{0}, bad_{0},
      refused_{0};
};

}  // namespace mrd::canbus
