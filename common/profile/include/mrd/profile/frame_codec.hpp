#pragma once
// Frames of a CAN device profile, for the real-time path of either side (the firmware and the
// harness playing the driver): which profile message a frame is, its checks (length, checksum,
// rolling counter), role values in and out, and sealing a frame to send (counter + checksum).
// No allocation, no exceptions, no I/O; the profile (can_profile.hpp) outlives the codec.
//
// Rolling counters of L bits (every message of the profile that names one): a sender adds 1
// mod 2^L per frame; a receiver refuses a counter equal to the last accepted one (repeated)
// and one 2^(L-1) or more ahead (stale: an old frame), resynchronising on it so a restarted
// sender loses one frame. With L = 4 this is the native frame set's rule (docs/can_bus.md).

#include <linux/can.h>

#include <array>
#include <cstdint>

#include "mrd/profile/can_profile.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::profile {

class FrameCodec {
 public:
  static constexpr std::size_t kMaxMessages = 64;

  // The profile must have at most kMaxMessages messages (LoadCanProfile checks it).
  explicit FrameCodec(const CanProfile& profile);

  const CanProfile& profile() const { return *profile_; }
  // The message index of a received frame (identifier and frame format), or -1.
  int Find(const can_frame& f) const;
  // The checks of message m on frame f: length, checksum, then the rolling counter (which the
  // codec then records). kNone when the frame may be used.
  protocol::can::Reject Check(int m, const can_frame& f);
  // A role's physical value from a frame of its message (range checked).
  protocol::SignalError Get(const can_frame& f, SignalRef r, double* value) const;
  // A zeroed frame of message m (identifier, format and length set).
  void Begin(int m, can_frame* f) const;
  // Writes a role's value; refuses (writing nothing) a non-finite or out-of-range one.
  protocol::SignalError Set(can_frame* f, SignalRef r, double value) const;
  // Adds the message's rolling counter (next value) and checksum, as its spec says.
  void Seal(int m, can_frame* f);
  // Forget the received counters (a peer that restarted).
  void ResetCounters();

 private:
  const CanProfile* profile_;
  std::array<std::uint8_t, kMaxMessages> tx_counter_{};
  std::array<std::uint8_t, kMaxMessages> rx_counter_{};
  std::array<bool, kMaxMessages> rx_seen_{};
};

// The CAN identifier of a message as it travels (CAN_EFF_FLAG set for a 29-bit one).
canid_t WireId(const DbcMessage& m);

}  // namespace mrd::profile
