#include "mrd/protocol/modbus_map.hpp"

namespace mrd::protocol::modbus {
namespace {

bool Put(const FieldScale& f, double value, std::uint16_t* regs) {
  std::uint32_t raw = 0;
  if (!Encode(f, value, &raw)) return false;
  if (f.bits == 32) {
    PutU32(raw, regs);
  } else {
    regs[0] = static_cast<std::uint16_t>(raw);
  }
  return true;
}

double Get(const FieldScale& f, const std::uint16_t* regs) {
  return Decode(f, f.bits == 32 ? GetU32(regs) : regs[0]);
}

}  // namespace

MapError EncodeSensors(const SensorBlock& in, std::uint16_t regs[kSensorCount]) {
  PutU32(in.seq, regs + kSeq);
  if (!Put(kVelocityScale, in.velocity, regs + kVelocity) ||
      !Put(kDisplacementScale, in.displacement, regs + kDisplacement) ||
      !Put(kForceScale, in.demand, regs + kDemand) ||
      !Put(kVelocityScale, in.body_velocity, regs + kBodyVelocity) ||
      !Put(kForceScale, in.force, regs + kForce)) {
    return MapError::kOutOfRange;
  }
  regs[kFaults] = static_cast<std::uint16_t>((in.fault_line ? kFaultLineBit : 0U) |
                                             (in.driver_fault ? kDriverFaultBit : 0U));
  return MapError::kOk;
}

MapError DecodeSensors(const std::uint16_t regs[kSensorCount], SensorBlock* out) {
  if ((regs[kFaults] & ~kKnownFaultBits) != 0) return MapError::kReservedBits;
  out->seq = GetU32(regs + kSeq);
  out->velocity = Get(kVelocityScale, regs + kVelocity);
  out->displacement = Get(kDisplacementScale, regs + kDisplacement);
  out->demand = Get(kForceScale, regs + kDemand);
  out->body_velocity = Get(kVelocityScale, regs + kBodyVelocity);
  out->force = Get(kForceScale, regs + kForce);
  out->fault_line = (regs[kFaults] & kFaultLineBit) != 0;
  out->driver_fault = (regs[kFaults] & kDriverFaultBit) != 0;
  return MapError::kOk;
}

MapError EncodeCommand(const CommandBlock& in, std::uint16_t regs[kCommandCount]) {
  PutU32(in.echo, regs + kEcho);
  if (in.has_set_point) {
    // The sentinel's raw value is the field's minimum: a real set-point never uses it.
    std::uint32_t raw = 0;
    if (!Encode(kSetPointScale, in.set_point, &raw) || raw == kNoSetPoint) {
      return MapError::kOutOfRange;
    }
    regs[kSetPoint] = static_cast<std::uint16_t>(raw);
  } else {
    regs[kSetPoint] = kNoSetPoint;
  }
  regs[kEnable] = in.enable_driven ? (in.enable ? 1 : 0) : kEnableNotDriven;
  regs[kHeartbeat] = in.heartbeat;
  regs[kState] = static_cast<std::uint16_t>((in.safe ? kStateSafeBit : 0U) |
                                            (in.has_status ? kStateStatusBit : 0U));
  regs[kCauses] = in.has_status ? in.causes : 0;
  PutU32(in.has_status ? in.ticks : 0U, regs + kTicks);
  return MapError::kOk;
}

MapError DecodeCommand(const std::uint16_t regs[kCommandCount], CommandBlock* out) {
  const std::uint16_t enable = regs[kEnable];
  if (enable != 0 && enable != 1 && enable != kEnableNotDriven) return MapError::kReservedBits;
  if ((regs[kState] & ~(kStateSafeBit | kStateStatusBit)) != 0) return MapError::kReservedBits;
  out->echo = GetU32(regs + kEcho);
  out->has_set_point = regs[kSetPoint] != kNoSetPoint;
  out->set_point = out->has_set_point ? Get(kSetPointScale, regs + kSetPoint) : 0.0;
  out->enable_driven = enable != kEnableNotDriven;
  out->enable = enable == 1;
  out->heartbeat = regs[kHeartbeat];
  out->safe = (regs[kState] & kStateSafeBit) != 0;
  out->has_status = (regs[kState] & kStateStatusBit) != 0;
  out->causes = regs[kCauses];
  out->ticks = GetU32(regs + kTicks);
  return MapError::kOk;
}

}  // namespace mrd::protocol::modbus
