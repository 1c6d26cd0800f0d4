#pragma once
// A CAN device profile: which message and signal of the driver's DBC carries each firmware
// signal, and how each message is protected (rolling counter, checksum), timed (transmit
// period, receive timeout) and filtered. Loaded once at configuration (all parsing and
// allocation happen here); the firmware's and the harness's CAN devices then run on the
// resolved indices with mrd::protocol's pure signal codec. File format: docs/devices.md.
//
//   name = "my-driver"                 dbc = "driver.dbc" (relative to the profile file)
//   [inputs]   velocity = "Msg.Signal" ...  (firmware inputs the bus serves)
//   [outputs]  command = "Msg.Signal" ...   (firmware outputs the bus carries)
//   [messages.Msg]  counter = "Signal"  checksum = "Signal"  checksum_kind = "crc8"|"sum8"
//                   crc_poly crc_init crc_xor  checksum_covers_id  period_ms  timeout_ms
//   [command]  unit = "A"  calibration = "coil.csv"  min  max  slew_per_s   (command_map.hpp)
//   [canopen]  node_id  own_node_id  ...  [[canopen.sdo]]   (a CiA 301 drive: canopen_profile.hpp)

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mrd/profile/canopen_profile.hpp"
#include "mrd/profile/command_map.hpp"
#include "mrd/profile/dbc.hpp"

namespace mrd::profile {

// Signals the firmware receives. Every role is optional; the firmware's [can] inputs say
// which it uses, and a role it uses must be mapped.
enum class CanIn : std::uint8_t {
  kVelocity = 0,        // relative damper velocity [cm/s]
  kDisplacement,        // relative displacement [cm]
  kDemand,              // force demand [N]
  kBodyVelocity,        // absolute body velocity [cm/s]
  kForce,               // measured force [N]
  kFaultLine,           // external fault input, non-zero = asserted
  kBodyAcceleration,    // absolute body acceleration [cm/s^2]
  kWheelVelocity,       // absolute wheel (unsprung) velocity [cm/s]
  kFloorAcceleration1,  // absolute floor accelerations of a structure [m/s^2]
  kFloorAcceleration2,
  kFloorAcceleration3,
  kSensorSeq,      // sensor sample number (echoed in the command: latency)
  kDriverFaults,   // driver fault bits, non-zero = a driver fault (safe state)
  kDriverCurrent,  // measured coil current [driver unit] (telemetry)
  kGrant,          // lockstep time grant [us] (simulation only: mrd-hil)
};
inline constexpr std::size_t kNumCanIn = 15;  // <= 16: role masks are 16-bit
// The first roles carry the firmware's inputs (velocity .. floor_acceleration_3): the firmware
// pairs them by name in one table (kInputRoles, mrd/firmware/io/input_roles.hpp).

// Signals the firmware sends.
enum class CanOut : std::uint8_t {
  kCommand = 0,        // set-point in the driver's unit (after the calibration)
  kEnable,             // driver enable, 1 = on
  kEnableValid,        // 1 when the enable travels on this bus
  kSafe,               // 1 while the firmware commands its safe state
  kEcho,               // the sensor seq the command was computed from
  kHeartbeatSafe,      // the heartbeat message's safe flag (the message is the heartbeat)
  kStatusSafe,         // firmware status: safe flag
  kStatusCauses,       // firmware status: active watchdog causes (bit i = cause i)
  kStatusOverruns,     // firmware status: loop overruns, saturating
  kStatusSafeEntries,  // firmware status: normal -> safe transitions, saturating
  kStatusModelForce,   // live telemetry: the model's force of the period [N]
  kStatusDemand,       // live telemetry: the force demand of the period [N]
  kStatusCommand,      // live telemetry: the command voltage E of the period [V]
  kFaultReset,         // 1 in one command frame: a latched driver fault's reset (an edge)
};
inline constexpr std::size_t kNumCanOut = 14;

const char* CanInName(CanIn role);
// The kNumCanIn input role names in CanIn order (the keys of a profile's [inputs] table,
// CAN and Modbus alike).
const char* const* CanInNames();
const char* CanOutName(CanOut role);

enum class ChecksumKind : std::uint8_t { kNone = 0, kCrc8, kSum8 };

// How one message is protected and timed.
struct MessageSpec {
  int message = -1;   // index into Dbc::messages
  int counter = -1;   // signal index of the rolling counter (+1 mod 2^length)
  int checksum = -1;  // signal index of the checksum (8 bits)
  ChecksumKind checksum_kind = ChecksumKind::kNone;
  std::uint8_t crc_poly = 0x1D, crc_init = 0xFF, crc_xor = 0xFF;
  bool checksum_covers_id = true;  // the id's low then high byte come before the data
  std::int64_t period_ns = 0;      // transmit period (0: every control period)
  std::int64_t timeout_ns = 0;     // receive timeout (0: the firmware's max_age)
  bool transmit = false;           // the firmware sends it (it carries an output role)
  bool receive = false;            // the firmware receives it (it carries an input role)
};

struct SignalRef {
  int message = -1;  // index into Dbc::messages (and CanProfile::specs)
  int signal = -1;   // index into DbcMessage::signals
  bool mapped() const { return message >= 0; }
};

struct CanProfile {
  std::string path;          // the profile file
  std::uint64_t digest = 0;  // of the profile, its DBC and calibration (a reload compares)
  std::string name;
  Dbc dbc;
  std::vector<MessageSpec> specs;  // one per DBC message, same index
  std::array<SignalRef, kNumCanIn> inputs{};
  std::array<SignalRef, kNumCanOut> outputs{};
  // E [V] -> the driver's set-point ([command]; identity without it).
  std::string command_unit = "V";
  CommandMap command;
  // [canopen]: the driver is a CiA 301 node (NMT, heartbeats, SYNC, start-up SDOs); absent
  // for a plain CAN driver.
  std::optional<CanopenConfig> canopen;
  const protocol::SignalLayout& Layout(SignalRef r) const {
    return dbc.messages[static_cast<std::size_t>(r.message)]
        .signals[static_cast<std::size_t>(r.signal)]
        .layout;
  }
};

// Reads a profile file and its DBC. On failure *error is "FILE:LINE: reason" (the profile's
// or the DBC's line). Checks: every role names an existing Message.Signal, no role twice, no
// signal carrying two roles, a message never both sent and received, counter and checksum
// signals of the right size and not carrying a role, fault_reset an unsigned 1-bit signal of
// a command message (one carrying command, enable, enable_valid, safe or echo), every key known.
bool LoadCanProfile(const std::string& path, CanProfile* out, std::string* error);
// The same from text: `path` names it in errors; with dbc_text the DBC is that text (named by
// the profile's `dbc` value) instead of the file the profile names.
bool ParseCanProfile(const std::string& text, const std::string& path, const std::string* dbc_text,
                     CanProfile* out, std::string* error);
// The built-in mrd-native profile (firmware/profiles/mrd-native.toml with docs/mrd.dbc,
// compiled in): the firmware's and the harness's default. Never fails on a correct build.
const CanProfile& NativeCanProfile();

// The checksum of a frame under a message's spec: CRC-8 (MSB first, the spec's polynomial,
// init and final xor) or the byte sum mod 256, over the identifier's bytes (little-endian: 2
// for an 11-bit id, 4 for a 29-bit one) when checksum_covers_id, then every payload byte of
// 0..dlc-1 that holds no bit of the checksum signal. Pure; used by both directions.
std::uint8_t FrameChecksum(const MessageSpec& spec, const protocol::SignalLayout& checksum,
                           std::uint32_t id, const std::uint8_t* data, int dlc);

}  // namespace mrd::profile
