#include "mrd/profile/frame_codec.hpp"

#include <cstring>

namespace mrd::profile {
namespace {

using protocol::can::Reject;

const protocol::SignalLayout& LayoutOf(const DbcMessage& m, int signal) {
  return m.signals[static_cast<std::size_t>(signal)].layout;
}

}  // namespace

canid_t WireId(const DbcMessage& m) { return m.extended ? (m.id | CAN_EFF_FLAG) : m.id; }

FrameCodec::FrameCodec(const CanProfile& profile) : profile_(&profile) {}

int FrameCodec::Find(const can_frame& f) const {
  if ((f.can_id & (CAN_RTR_FLAG | CAN_ERR_FLAG)) != 0) return -1;
  const bool ext = (f.can_id & CAN_EFF_FLAG) != 0;
  const canid_t id = f.can_id & (ext ? CAN_EFF_MASK : CAN_SFF_MASK);
  const auto& msgs = profile_->dbc.messages;
  for (std::size_t m = 0; m < msgs.size(); ++m) {
    if (msgs[m].id == id && msgs[m].extended == ext) return static_cast<int>(m);
  }
  return -1;
}

Reject FrameCodec::Check(int m, const can_frame& f) {
  const auto mi = static_cast<std::size_t>(m);
  const DbcMessage& msg = profile_->dbc.messages[mi];
  const MessageSpec& spec = profile_->specs[mi];
  if (f.len != msg.dlc) return Reject::kWrongDlc;
  if (spec.checksum >= 0) {
    const auto& ck = LayoutOf(msg, spec.checksum);
    const auto want = FrameChecksum(spec, ck, msg.id, f.data, msg.dlc);
    if (static_cast<std::uint8_t>(protocol::ExtractRaw(f.data, ck)) != want) {
      return Reject::kBadChecksum;
    }
  }
  if (spec.counter >= 0) {
    const auto& c = LayoutOf(msg, spec.counter);
    const auto mod = static_cast<unsigned>(1U << c.length);
    const auto counter = static_cast<std::uint8_t>(protocol::ExtractRaw(f.data, c));
    if (!rx_seen_[mi]) {
      rx_seen_[mi] = true;
      rx_counter_[mi] = counter;
      return Reject::kNone;
    }
    const unsigned ahead = (counter - rx_counter_[mi]) & (mod - 1U);
    if (ahead == 0) return Reject::kRepeatedCounter;
    rx_counter_[mi] = counter;
    if (ahead >= mod / 2) return Reject::kStaleCounter;
  }
  return Reject::kNone;
}

protocol::SignalError FrameCodec::Get(const can_frame& f, SignalRef r, double* value) const {
  return protocol::DecodeSignal(f.data, profile_->Layout(r), value);
}

void FrameCodec::Begin(int m, can_frame* f) const {
  const DbcMessage& msg = profile_->dbc.messages[static_cast<std::size_t>(m)];
  std::memset(f, 0, sizeof *f);
  f->can_id = WireId(msg);
  f->len = static_cast<std::uint8_t>(msg.dlc);
}

protocol::SignalError FrameCodec::Set(can_frame* f, SignalRef r, double value) const {
  return protocol::EncodeSignal(f->data, profile_->Layout(r), value);
}

void FrameCodec::Seal(int m, can_frame* f) {
  const auto mi = static_cast<std::size_t>(m);
  const DbcMessage& msg = profile_->dbc.messages[mi];
  const MessageSpec& spec = profile_->specs[mi];
  if (spec.counter >= 0) {
    const auto& c = LayoutOf(msg, spec.counter);
    protocol::InsertRaw(f->data, c, tx_counter_[mi]);
    tx_counter_[mi] = static_cast<std::uint8_t>((tx_counter_[mi] + 1U) & ((1U << c.length) - 1U));
  }
  if (spec.checksum >= 0) {
    const auto& ck = LayoutOf(msg, spec.checksum);
    protocol::InsertRaw(f->data, ck, FrameChecksum(spec, ck, msg.id, f->data, msg.dlc));
  }
}

void FrameCodec::ResetCounters() { rx_seen_.fill(false); }

}  // namespace mrd::profile
