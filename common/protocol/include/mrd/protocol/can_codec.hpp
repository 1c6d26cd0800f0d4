#pragma once
// The CAN frame set of docs/mrd.dbc on `struct can_frame` (<linux/can.h>): IDs, layout,
// scaling, ranges, the 4-bit rolling counter and the CRC-8 checksum. The firmware's CAN device
// and the HIL harness use its IDs, reject reasons and checksum; their frames are built and
// checked by the DBC-driven profile::FrameCodec (mrd-native profile). Encode/Decode here are
// a hand-written reference codec of the native frames that the tests hold that codec and the
// DBC to. Pure: no I/O, no allocation, no exceptions.
//
// All frames are CAN 2.0A data frames (11-bit IDs), signals little-endian (Intel) at fixed
// byte positions. Safety-relevant frames (sensor motion, sensor force, time grant, driver
// command, heartbeat, driver status) carry
//   counter   4 bits, low nibble of byte len-2 (byte 0 for the 2-byte heartbeat), +1 mod 16
//             per frame of that ID from the same sender
//   checksum  CRC-8 SAE J1850 (poly 0x1D, init 0xFF, xor-out 0xFF) over the ID's low byte,
//             the ID's high byte, then data[0 .. len-2]; stored in the last byte
// The firmware status frame is telemetry: no counter check, no checksum.

#include <linux/can.h>

#include <cstdint>

namespace mrd::protocol::can {

inline constexpr canid_t kDriverCommandId = 0x080;   // firmware -> driver, every period
inline constexpr canid_t kHeartbeatId = 0x081;       // firmware -> driver, heartbeat_period
inline constexpr canid_t kSensorMotionId = 0x100;    // sensors -> firmware, every period
inline constexpr canid_t kSensorForceId = 0x101;     // sensors -> firmware, every period
inline constexpr canid_t kTimeGrantId = 0x102;       // harness -> firmware, lockstep only
inline constexpr canid_t kDriverStatusId = 0x180;    // driver -> firmware
inline constexpr canid_t kFirmwareStatusId = 0x300;  // firmware -> anyone, status_period

inline constexpr std::uint8_t kHeartbeatDlc = 2;
inline constexpr std::uint8_t kFrameDlc = 8;  // every other frame

// Why a frame was refused (decode) or could not be built (encode).
enum class Reject : std::uint8_t {
  kNone = 0,
  kUnknownId,        // not an ID of the set, or not a standard data frame (EFF, RTR, error)
  kWrongDlc,         // length differs from the DBC
  kBadChecksum,      // CRC-8 mismatch
  kRepeatedCounter,  // same rolling counter as the last accepted frame of this ID
  kStaleCounter,     // counter behind (more than kMaxCounterGap ahead): an old frame
  kOutOfRange,       // a signal outside its DBC range [min|max]
  kNonFinite,        // encode only: NaN or infinity
};
inline constexpr std::size_t kNumRejects = 8;
// Static name ("none", "unknown_id", "wrong_dlc", "bad_checksum", "repeated_counter",
// "stale_counter", "out_of_range", "non_finite").
const char* RejectName(Reject reject);

enum class Message : std::uint8_t {
  kUnknown = 0,
  kDriverCommand,
  kHeartbeat,
  kSensorMotion,
  kSensorForce,
  kTimeGrant,
  kDriverStatus,
  kFirmwareStatus,
};
// The message a frame claims to be by its ID (kUnknown for EFF/RTR/error frames too).
Message Classify(const can_frame& frame);

// Physical ranges (the DBC's [min|max]).
inline constexpr double kMaxVelocity = 300.0;     // [cm/s], |v|, 0.01 cm/s per count
inline constexpr double kMaxDisplacement = 30.0;  // [cm], |x|, 0.001 cm per count
inline constexpr double kMaxForce = 15000.0;      // [N], |F| and |demand|, 0.5 N per count
inline constexpr double kMaxVoltage = 24.0;       // [V], set-point in [0, 24], 1 mV per count
inline constexpr double kMaxCurrent = 10.0;       // [A], measured current in [0, 10], 1 mA

struct SensorMotion {
  double velocity = 0.0;      // [cm/s]
  double displacement = 0.0;  // [cm]
  std::uint16_t seq = 0;      // sensor step number mod 2^16 (echoed by the driver command)
  std::uint8_t counter = 0;   // 0..15
};

struct SensorForce {
  double demand = 0.0;         // [N]
  double body_velocity = 0.0;  // [cm/s]
  double force = 0.0;          // measured damper force [N]
  std::uint8_t counter = 0;
};

// Lockstep (HIL): the harness grants the firmware's clock time up to time_us, after the
// sensor frames of that step. 48-bit microseconds (8.9 years).
inline constexpr std::uint64_t kMaxGrantUs = (std::uint64_t{1} << 48) - 1;
struct TimeGrant {
  std::uint64_t time_us = 0;  // granted harness time [us]
  std::uint8_t counter = 0;
};

struct DriverCommand {
  double volts = 0.0;          // set-point [V], in [0, 24]
  bool enable = false;         // driver enable
  bool enable_valid = false;   // the enable bit is routed to CAN (else another bus drives it)
  bool safe = true;            // the firmware commands its safe state
  std::uint16_t echo_seq = 0;  // seq of the latest sensor motion frame the command used
  std::uint8_t counter = 0;
};

struct Heartbeat {
  bool safe = true;          // firmware in its safe state
  std::uint8_t counter = 0;  // also the heartbeat's toggle
};

// Driver fault bits (DriverStatus.faults).
inline constexpr std::uint8_t kFaultOvercurrent = 1U << 0;
inline constexpr std::uint8_t kFaultOvertemperature = 1U << 1;
inline constexpr std::uint8_t kFaultUndervoltage = 1U << 2;
inline constexpr std::uint8_t kFaultHeartbeatLost = 1U << 3;
inline constexpr std::uint8_t kFaultCoilOpen = 1U << 4;

struct DriverStatus {
  double current = 0.0;     // measured coil current [A]
  std::uint8_t faults = 0;  // kFault* bits
  std::uint8_t counter = 0;
};

struct FirmwareStatus {
  bool safe = true;
  std::uint16_t active_causes = 0;  // bit i = watchdog FaultCause i
  std::uint16_t overruns = 0;       // saturating at 65535
  std::uint16_t safe_entries = 0;   // saturating at 65535
  std::uint8_t sequence = 0;        // +1 mod 256 per status frame
};

// Encoders fill *frame (ID, length, data, counter, checksum) and return kNone, or refuse
// (kNonFinite / kOutOfRange) and leave *frame untouched: a sender never wraps a value.
Reject Encode(const SensorMotion& m, can_frame* frame);
Reject Encode(const SensorForce& m, can_frame* frame);
Reject Encode(const DriverCommand& m, can_frame* frame);
Reject Encode(const TimeGrant& m, can_frame* frame);
Reject Encode(const Heartbeat& m, can_frame* frame);
Reject Encode(const DriverStatus& m, can_frame* frame);
Reject Encode(const FirmwareStatus& m, can_frame* frame);

// Decoders check ID, length, checksum and ranges (not the counter: CounterCheck, per ID and
// sender); kNone fills *m, anything else leaves it untouched.
Reject Decode(const can_frame& frame, SensorMotion* m);
Reject Decode(const can_frame& frame, SensorForce* m);
Reject Decode(const can_frame& frame, DriverCommand* m);
Reject Decode(const can_frame& frame, TimeGrant* m);
Reject Decode(const can_frame& frame, Heartbeat* m);
Reject Decode(const can_frame& frame, DriverStatus* m);
Reject Decode(const can_frame& frame, FirmwareStatus* m);

// CRC-8 SAE J1850 of a frame as defined above (over ID and data[0 .. len-2]); len >= 1.
std::uint8_t Checksum(const can_frame& frame);

// Counter gap still accepted (frames lost on the way): 1..kMaxCounterGap ahead.
inline constexpr std::uint8_t kMaxCounterGap = 7;

// The receiver's rolling-counter check for one ID. The first frame after Reset is accepted.
// A repeated counter is refused and changes nothing; a stale one (8..15 ahead, i.e. behind)
// is refused and resynchronises to it, so a restarted sender loses one frame, not all.
class CounterCheck {
 public:
  Reject Check(std::uint8_t counter);
  void Reset() { seen_ = false; }

 private:
  bool seen_ = false;
  std::uint8_t last_ = 0;
};

}  // namespace mrd::protocol::can
