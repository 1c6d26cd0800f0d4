#pragma once
// The local frame bus: a CAN bus stand-in for machines without AF_CAN. A relay listens on a
// UNIX SOCK_SEQPACKET socket; every node (OpenLocalBusNode) sends one `struct can_frame` per
// packet, and the relay hands each frame to every other node, as on a CAN bus (a node does not
// hear its own frames, like CAN_RAW without CAN_RAW_RECV_OWN_MSGS). Packets of another size
// are dropped and counted. A node whose receive buffer is full loses the frame (counted), as a
// CAN controller with a full FIFO does; the relay never blocks on a slow node.
//
// Run it as its own process (mrd-canbus --socket PATH) or in-process on a thread (the HIL's
// CAN port does when the socket does not exist yet). Not real-time: it allocates as nodes come.

#include <poll.h>

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

namespace mrd::canbus {

struct RelayStats {
  std::uint64_t nodes_joined = 0;
  std::uint64_t nodes_left = 0;
  std::uint64_t frames_in = 0;
  std::uint64_t frames_out = 0;      // deliveries (frames_in x other nodes, minus drops)
  std::uint64_t frames_dropped = 0;  // deliveries lost to a full node
  std::uint64_t bad_packets = 0;     // not one can_frame
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
  // One round: waits up to timeout_ms for activity, accepts nodes, forwards frames.
  void Step(int timeout_ms);
  // Steps until stop is set.
  void Run(const std::atomic<bool>& stop);
  // Closes every node and the listener, removes the socket file. Idempotent.
  void Close();

  std::size_t nodes() const { return nodes_.size(); }

  // An in-process node (the HIL harness, which owns the relay): Broadcast hands a frame to every
  // socket node; the tap receives every frame a socket node sends (from Step, on the calling
  // thread). Saves the harness's own socket round trip per frame.
  void Broadcast(const void* frame);
  using Tap = void (*)(void* context, const void* frame);
  void SetTap(Tap tap, void* context) {
    tap_ = tap;
    tap_context_ = context;
  }
  // Safe to call from another thread while Run is going (each field is read atomically).
  RelayStats stats() const;

 private:
  void Forward(std::size_t from, const void* frame);
  void Drop(std::size_t i);

  std::string path_;
  Tap tap_ = nullptr;
  void* tap_context_ = nullptr;
  int listen_fd_ = -1;
  std::vector<int> nodes_;
  // Step's scratch (kept: no allocation per round once the node count is steady).
  std::vector<pollfd> fds_;
  std::vector<char> gone_;
  std::atomic<std::uint64_t> joined_{0}, left_{0}, in_{0}, out_{0}, dropped_{0}, bad_{0};
};

}  // namespace mrd::canbus
