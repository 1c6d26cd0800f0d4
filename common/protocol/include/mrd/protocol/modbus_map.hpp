#pragma once
// The Modbus register map of the damper I/O (reference: docs/modbus_registers.md), shared by
// the firmware's client and the harness's server. All registers are holding registers
// (function 0x03 reads, 0x10 writes). 32-bit values take two registers, HIGH word first
// (big-endian word order, as the register bytes themselves). Pure code: no I/O, no allocation.
//
// Sensor block (server -> firmware, read-only: a write gets ILLEGAL DATA ADDRESS), read in one
// request of kSensorCount registers at kSensorBase:
//   0-1  seq            u32   sensor sample number, +1 per plant step (wraps)
//   2-3  velocity       i32   1e-4 cm/s
//   4-5  displacement   i32   1e-5 cm
//   6-7  demand         i32   1e-2 N
//   8-9  body_velocity  i32   1e-4 cm/s
//   10-11 force         i32   1e-2 N
//   12   faults         u16   bit 0 external fault line, bit 1 driver fault; others 0
//   13-15 grant         u48   lockstep only: harness time granted [us], high word first; 0 =
//                             no grant yet. A lockstep client reads kLockstepSensorCount
//                             registers (sensors and grant in one request)
// Command block (firmware -> server), written in one request of kCommandCount registers:
//   32-33 echo          u32   seq of the latest sensor block the loop had read
//   34   set_point      i16   1e-3 V; kNoSetPoint (0x8000) when the command goes elsewhere
//   35   enable         u16   0 off, 1 on; kEnableNotDriven (0xFFFF) when not routed here
//   36   heartbeat      u16   loop period count (low 16 bits); changes every period while
//                             the loop runs, 0 when the heartbeat is not routed here
//   37   state          u16   bit 0 safe state commanded, bit 1 status routed here
//   38   causes         u16   watchdog causes active (bit i = FaultCause i), 0 if not routed
//   39-40 ticks         u32   loop periods since start (low 32 bits), 0 if not routed

#include <cstdint>

#include "mrd/protocol/scaling.hpp"

namespace mrd::protocol::modbus {

inline constexpr int kSensorBase = 0;
inline constexpr int kSensorCount = 13;
inline constexpr int kLockstepSensorCount = 16;  // + the grant (13-15)
inline constexpr int kCommandBase = 32;
inline constexpr int kCommandCount = 9;
inline constexpr int kMapSize = 48;  // registers a server holds (0..47); beyond: exception

// Register offsets within each block.
inline constexpr int kSeq = 0;
inline constexpr int kVelocity = 2;
inline constexpr int kDisplacement = 4;
inline constexpr int kDemand = 6;
inline constexpr int kBodyVelocity = 8;
inline constexpr int kForce = 10;
inline constexpr int kFaults = 12;
inline constexpr int kGrant = 13;
inline constexpr int kEcho = 0;
inline constexpr int kSetPoint = 2;
inline constexpr int kEnable = 3;
inline constexpr int kHeartbeat = 4;
inline constexpr int kState = 5;
inline constexpr int kCauses = 6;
inline constexpr int kTicks = 7;

inline constexpr std::uint16_t kFaultLineBit = 1U << 0;
inline constexpr std::uint16_t kDriverFaultBit = 1U << 1;
inline constexpr std::uint16_t kKnownFaultBits = kFaultLineBit | kDriverFaultBit;
inline constexpr std::uint16_t kNoSetPoint = 0x8000;
inline constexpr std::uint16_t kEnableNotDriven = 0xFFFF;
inline constexpr std::uint16_t kStateSafeBit = 1U << 0;
inline constexpr std::uint16_t kStateStatusBit = 1U << 1;

inline constexpr FieldScale kVelocityScale{1e-4, 0.0, 32, true};      // [cm/s]
inline constexpr FieldScale kDisplacementScale{1e-5, 0.0, 32, true};  // [cm]
inline constexpr FieldScale kForceScale{1e-2, 0.0, 32, true};         // [N] (demand, force)
inline constexpr FieldScale kSetPointScale{1e-3, 0.0, 16, true};      // [V]

struct SensorBlock {
  std::uint32_t seq = 0;
  double velocity = 0.0;       // [cm/s]
  double displacement = 0.0;   // [cm]
  double demand = 0.0;         // [N]
  double body_velocity = 0.0;  // [cm/s]
  double force = 0.0;          // [N]
  bool fault_line = false;
  bool driver_fault = false;
};

struct CommandBlock {
  std::uint32_t echo = 0;
  bool has_set_point = false;
  double set_point = 0.0;  // [V]
  bool enable_driven = false;
  bool enable = false;
  std::uint16_t heartbeat = 0;
  bool has_status = false;
  bool safe = true;
  std::uint16_t causes = 0;
  std::uint32_t ticks = 0;
};

// Why a block does not encode or decode.
enum class MapError : std::uint8_t {
  kOk = 0,
  kOutOfRange,    // a value outside its field (or non-finite): nothing is sent
  kReservedBits,  // a reserved bit or an unknown enable code is set
};

// Encoders fill regs[0..count) and return kOk, or kOutOfRange leaving regs unspecified.
MapError EncodeSensors(const SensorBlock& in, std::uint16_t regs[kSensorCount]);
MapError EncodeCommand(const CommandBlock& in, std::uint16_t regs[kCommandCount]);
// Decoders: kReservedBits when the block holds codes the map does not define.
MapError DecodeSensors(const std::uint16_t regs[kSensorCount], SensorBlock* out);
MapError DecodeCommand(const std::uint16_t regs[kCommandCount], CommandBlock* out);

// 32-bit value as two registers, high word first.
inline void PutU32(std::uint32_t v, std::uint16_t* regs) {
  regs[0] = static_cast<std::uint16_t>(v >> 16);
  regs[1] = static_cast<std::uint16_t>(v & 0xFFFFU);
}
inline std::uint32_t GetU32(const std::uint16_t* regs) {
  return (static_cast<std::uint32_t>(regs[0]) << 16) | regs[1];
}
// 48-bit value (the grant [us]) as three registers, high word first; bits above 47 dropped.
inline void PutU48(std::uint64_t v, std::uint16_t* regs) {
  regs[0] = static_cast<std::uint16_t>((v >> 32) & 0xFFFFU);
  regs[1] = static_cast<std::uint16_t>((v >> 16) & 0xFFFFU);
  regs[2] = static_cast<std::uint16_t>(v & 0xFFFFU);
}
inline std::uint64_t GetU48(const std::uint16_t* regs) {
  return (static_cast<std::uint64_t>(regs[0]) << 32) | (static_cast<std::uint64_t>(regs[1]) << 16) |
         regs[2];
}

}  // namespace mrd::protocol::modbus
