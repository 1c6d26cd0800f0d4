#include "mrd/protocol/can_codec.hpp"

#include <cmath>
#include <cstring>

#include "mrd/protocol/scaling.hpp"

namespace mrd::protocol::can {
namespace {

// A signal: its field and its physical range (the DBC's [min|max]).
struct Signal {
  FieldScale field;
  double min, max;
  int byte;  // first byte (little-endian)
};

constexpr Signal kVelocity{{0.01, 0.0, 16, true}, -kMaxVelocity, kMaxVelocity, 0};
constexpr Signal kDisplacement{{0.001, 0.0, 16, true}, -kMaxDisplacement, kMaxDisplacement, 2};
constexpr Signal kDemand{{0.5, 0.0, 16, true}, -kMaxForce, kMaxForce, 0};
constexpr Signal kBodyVelocity{{0.01, 0.0, 16, true}, -kMaxVelocity, kMaxVelocity, 2};
constexpr Signal kForce{{0.5, 0.0, 16, true}, -kMaxForce, kMaxForce, 4};
constexpr Signal kVoltage{{0.001, 0.0, 16, false}, 0.0, kMaxVoltage, 0};
constexpr Signal kCurrent{{0.001, 0.0, 16, false}, 0.0, kMaxCurrent, 0};

constexpr int kCounterByte = kFrameDlc - 2;  // low nibble, 8-byte frames
constexpr int kHeartbeatCounterByte = 0;

void Put16(can_frame* f, int byte, std::uint32_t raw) {
  f->data[byte] = static_cast<std::uint8_t>(raw & 0xFFU);
  f->data[byte + 1] = static_cast<std::uint8_t>((raw >> 8) & 0xFFU);
}
std::uint32_t Get16(const can_frame& f, int byte) {
  return static_cast<std::uint32_t>(f.data[byte]) |
         (static_cast<std::uint32_t>(f.data[byte + 1]) << 8);
}

// Encodes s into *raw, or says why not.
Reject EncodeSignal(const Signal& s, double value, std::uint32_t* raw) {
  if (!std::isfinite(value)) return Reject::kNonFinite;
  if (value < s.min || value > s.max) return Reject::kOutOfRange;
  return protocol::Encode(s.field, value, raw) ? Reject::kNone : Reject::kOutOfRange;
}
Reject DecodeSignal(const Signal& s, const can_frame& f, double* value) {
  const double v = protocol::Decode(s.field, Get16(f, s.byte));
  // Half a count of slack: the range limits are themselves on the grid.
  const double slack = 0.5 * s.field.scale;
  if (v < s.min - slack || v > s.max + slack) return Reject::kOutOfRange;
  *value = v;
  return Reject::kNone;
}

void Start(canid_t id, std::uint8_t len, can_frame* f) {
  std::memset(f, 0, sizeof *f);
  f->can_id = id;
  f->len = len;
}
void Seal(std::uint8_t counter, int counter_byte, can_frame* f) {
  f->data[counter_byte] =
      static_cast<std::uint8_t>((f->data[counter_byte] & 0xF0U) | (counter & 0x0FU));
  f->data[f->len - 1] = Checksum(*f);
}

// ID, length and (when sealed) checksum.
Reject CheckFrame(const can_frame& f, canid_t id, std::uint8_t len, bool sealed) {
  if ((f.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) != 0 || f.can_id != id) {
    return Reject::kUnknownId;
  }
  if (f.len != len) return Reject::kWrongDlc;
  if (sealed && f.data[len - 1] != Checksum(f)) return Reject::kBadChecksum;
  return Reject::kNone;
}

}  // namespace

const char* RejectName(Reject reject) {
  switch (reject) {
    case Reject::kNone:
      return "none";
    case Reject::kUnknownId:
      return "unknown_id";
    case Reject::kWrongDlc:
      return "wrong_dlc";
    case Reject::kBadChecksum:
      return "bad_checksum";
    case Reject::kRepeatedCounter:
      return "repeated_counter";
    case Reject::kStaleCounter:
      return "stale_counter";
    case Reject::kOutOfRange:
      return "out_of_range";
    case Reject::kNonFinite:
      return "non_finite";
  }
  return "?";
}

Message Classify(const can_frame& frame) {
  if ((frame.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) != 0) return Message::kUnknown;
  switch (frame.can_id) {
    case kDriverCommandId:
      return Message::kDriverCommand;
    case kHeartbeatId:
      return Message::kHeartbeat;
    case kSensorMotionId:
      return Message::kSensorMotion;
    case kSensorForceId:
      return Message::kSensorForce;
    case kTimeGrantId:
      return Message::kTimeGrant;
    case kDriverStatusId:
      return Message::kDriverStatus;
    case kFirmwareStatusId:
      return Message::kFirmwareStatus;
    default:
      return Message::kUnknown;
  }
}

std::uint8_t Checksum(const can_frame& frame) {
  std::uint8_t crc = 0xFF;
  const auto feed = [&crc](std::uint8_t byte) {
    crc ^= byte;
    for (int i = 0; i < 8; ++i) {
      crc = (crc & 0x80U) != 0 ? static_cast<std::uint8_t>((crc << 1) ^ 0x1DU)
                               : static_cast<std::uint8_t>(crc << 1);
    }
  };
  const canid_t id = frame.can_id & CAN_SFF_MASK;
  feed(static_cast<std::uint8_t>(id & 0xFFU));
  feed(static_cast<std::uint8_t>((id >> 8) & 0xFFU));
  const int n = frame.len > 0 ? frame.len - 1 : 0;
  for (int i = 0; i < n && i < CAN_MAX_DLEN; ++i) feed(frame.data[i]);
  return static_cast<std::uint8_t>(crc ^ 0xFFU);
}

Reject Encode(const SensorMotion& m, can_frame* frame) {
  std::uint32_t v = 0, x = 0;
  Reject r = EncodeSignal(kVelocity, m.velocity, &v);
  if (r == Reject::kNone) r = EncodeSignal(kDisplacement, m.displacement, &x);
  if (r != Reject::kNone) return r;
  Start(kSensorMotionId, kFrameDlc, frame);
  Put16(frame, kVelocity.byte, v);
  Put16(frame, kDisplacement.byte, x);
  Put16(frame, 4, m.seq);
  Seal(m.counter, kCounterByte, frame);
  return Reject::kNone;
}

Reject Encode(const SensorForce& m, can_frame* frame) {
  std::uint32_t d = 0, b = 0, f = 0;
  Reject r = EncodeSignal(kDemand, m.demand, &d);
  if (r == Reject::kNone) r = EncodeSignal(kBodyVelocity, m.body_velocity, &b);
  if (r == Reject::kNone) r = EncodeSignal(kForce, m.force, &f);
  if (r != Reject::kNone) return r;
  Start(kSensorForceId, kFrameDlc, frame);
  Put16(frame, kDemand.byte, d);
  Put16(frame, kBodyVelocity.byte, b);
  Put16(frame, kForce.byte, f);
  Seal(m.counter, kCounterByte, frame);
  return Reject::kNone;
}

Reject Encode(const DriverCommand& m, can_frame* frame) {
  std::uint32_t v = 0;
  const Reject r = EncodeSignal(kVoltage, m.volts, &v);
  if (r != Reject::kNone) return r;
  Start(kDriverCommandId, kFrameDlc, frame);
  Put16(frame, kVoltage.byte, v);
  frame->data[2] = static_cast<std::uint8_t>((m.enable ? 1U : 0U) | (m.enable_valid ? 2U : 0U) |
                                             (m.safe ? 4U : 0U));
  Put16(frame, 4, m.echo_seq);
  Seal(m.counter, kCounterByte, frame);
  return Reject::kNone;
}

Reject Encode(const TimeGrant& m, can_frame* frame) {
  if (m.time_us > kMaxGrantUs) return Reject::kOutOfRange;
  Start(kTimeGrantId, kFrameDlc, frame);
  for (int i = 0; i < 6; ++i)
    frame->data[i] = static_cast<std::uint8_t>((m.time_us >> (8 * i)) & 0xFFU);
  Seal(m.counter, kCounterByte, frame);
  return Reject::kNone;
}

Reject Encode(const Heartbeat& m, can_frame* frame) {
  Start(kHeartbeatId, kHeartbeatDlc, frame);
  frame->data[0] = m.safe ? 0x10U : 0x00U;
  Seal(m.counter, kHeartbeatCounterByte, frame);
  return Reject::kNone;
}

Reject Encode(const DriverStatus& m, can_frame* frame) {
  std::uint32_t c = 0;
  const Reject r = EncodeSignal(kCurrent, m.current, &c);
  if (r != Reject::kNone) return r;
  Start(kDriverStatusId, kFrameDlc, frame);
  Put16(frame, kCurrent.byte, c);
  frame->data[2] = m.faults;
  Seal(m.counter, kCounterByte, frame);
  return Reject::kNone;
}

Reject Encode(const FirmwareStatus& m, can_frame* frame) {
  Start(kFirmwareStatusId, kFrameDlc, frame);
  frame->data[0] = m.safe ? 1U : 0U;
  Put16(frame, 1, m.active_causes);
  Put16(frame, 3, m.overruns);
  Put16(frame, 5, m.safe_entries);
  frame->data[7] = m.sequence;
  return Reject::kNone;
}

Reject Decode(const can_frame& frame, SensorMotion* m) {
  Reject r = CheckFrame(frame, kSensorMotionId, kFrameDlc, true);
  SensorMotion out;
  if (r == Reject::kNone) r = DecodeSignal(kVelocity, frame, &out.velocity);
  if (r == Reject::kNone) r = DecodeSignal(kDisplacement, frame, &out.displacement);
  if (r != Reject::kNone) return r;
  out.seq = static_cast<std::uint16_t>(Get16(frame, 4));
  out.counter = frame.data[kCounterByte] & 0x0FU;
  *m = out;
  return Reject::kNone;
}

Reject Decode(const can_frame& frame, SensorForce* m) {
  Reject r = CheckFrame(frame, kSensorForceId, kFrameDlc, true);
  SensorForce out;
  if (r == Reject::kNone) r = DecodeSignal(kDemand, frame, &out.demand);
  if (r == Reject::kNone) r = DecodeSignal(kBodyVelocity, frame, &out.body_velocity);
  if (r == Reject::kNone) r = DecodeSignal(kForce, frame, &out.force);
  if (r != Reject::kNone) return r;
  out.counter = frame.data[kCounterByte] & 0x0FU;
  *m = out;
  return Reject::kNone;
}

Reject Decode(const can_frame& frame, DriverCommand* m) {
  Reject r = CheckFrame(frame, kDriverCommandId, kFrameDlc, true);
  DriverCommand out;
  if (r == Reject::kNone) r = DecodeSignal(kVoltage, frame, &out.volts);
  if (r != Reject::kNone) return r;
  out.enable = (frame.data[2] & 1U) != 0;
  out.enable_valid = (frame.data[2] & 2U) != 0;
  out.safe = (frame.data[2] & 4U) != 0;
  out.echo_seq = static_cast<std::uint16_t>(Get16(frame, 4));
  out.counter = frame.data[kCounterByte] & 0x0FU;
  *m = out;
  return Reject::kNone;
}

Reject Decode(const can_frame& frame, TimeGrant* m) {
  const Reject r = CheckFrame(frame, kTimeGrantId, kFrameDlc, true);
  if (r != Reject::kNone) return r;
  std::uint64_t t = 0;
  for (int i = 0; i < 6; ++i) t |= static_cast<std::uint64_t>(frame.data[i]) << (8 * i);
  m->time_us = t;
  m->counter = frame.data[kCounterByte] & 0x0FU;
  return Reject::kNone;
}

Reject Decode(const can_frame& frame, Heartbeat* m) {
  const Reject r = CheckFrame(frame, kHeartbeatId, kHeartbeatDlc, true);
  if (r != Reject::kNone) return r;
  m->safe = (frame.data[0] & 0x10U) != 0;
  m->counter = frame.data[kHeartbeatCounterByte] & 0x0FU;
  return Reject::kNone;
}

Reject Decode(const can_frame& frame, DriverStatus* m) {
  Reject r = CheckFrame(frame, kDriverStatusId, kFrameDlc, true);
  DriverStatus out;
  if (r == Reject::kNone) r = DecodeSignal(kCurrent, frame, &out.current);
  if (r != Reject::kNone) return r;
  out.faults = frame.data[2];
  out.counter = frame.data[kCounterByte] & 0x0FU;
  *m = out;
  return Reject::kNone;
}

Reject Decode(const can_frame& frame, FirmwareStatus* m) {
  const Reject r = CheckFrame(frame, kFirmwareStatusId, kFrameDlc, false);
  if (r != Reject::kNone) return r;
  m->safe = (frame.data[0] & 1U) != 0;
  m->active_causes = static_cast<std::uint16_t>(Get16(frame, 1));
  m->overruns = static_cast<std::uint16_t>(Get16(frame, 3));
  m->safe_entries = static_cast<std::uint16_t>(Get16(frame, 5));
  m->sequence = frame.data[7];
  return Reject::kNone;
}

Reject CounterCheck::Check(std::uint8_t counter) {
  counter &= 0x0FU;
  if (!seen_) {
    seen_ = true;
    last_ = counter;
    return Reject::kNone;
  }
  const auto ahead = static_cast<std::uint8_t>((counter - last_) & 0x0FU);
  if (ahead == 0) return Reject::kRepeatedCounter;
  last_ = counter;
  return ahead <= kMaxCounterGap ? Reject::kNone : Reject::kStaleCounter;
}

}  // namespace mrd::protocol::can
