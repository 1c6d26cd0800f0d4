#pragma once
// A Modbus device profile: which unit, table, address and type carries each firmware signal,
// how 32-bit values are ordered, which write function the device takes, and how the model's
// command E [V] becomes the driver's set-point. Loaded once at configuration (all parsing,
// grouping and allocation here); the firmware's Modbus device and the harness's server then
// run on the resolved requests with the pure codec below. File format: docs/devices.md.
//
//   name = "..."  description = "..."
//   [modbus]  word_order = "big"|"swapped"  write_function = 16|6  align32 = bool  max_read
//             fault_reset_ms
//   [modbus.inputs]   role = { unit, table, address, type, scale, offset, word_order }
//   [modbus.outputs]  role = { ... }
//   [[modbus.startup]]  { unit, table, address, value }           written once per connection
//   [[modbus.periodic]] { unit, table, address, value, period_ms, watchdog_ms }  kept alive
//   [command]         unit calibration min max slew_per_s (command_map.hpp)
//
// Physical value = raw * scale + offset. Reads are grouped: the points of one unit and table
// sorted by address, a gap of at most kMaxGap registers (coils: bits) bridged, a request no
// longer than max_read. Writes: holding registers with 0x10 (contiguous points of one unit
// in one request) or 0x06 (one register each); coils with 0x0F or 0x05 likewise. The request
// carrying `command` is written last in a cycle (the harness takes it as the cycle's end).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "mrd/profile/can_profile.hpp"  // CanIn: the input roles are the CAN profile's
#include "mrd/profile/command_map.hpp"

namespace mrd::profile {

enum class ModbusTable : std::uint8_t { kCoil = 0, kDiscrete, kHolding, kInput };
enum class ModbusType : std::uint8_t { kInt16 = 0, kUint16, kInt32, kUint32, kFloat32, kBit };

// Signals the firmware writes.
enum class ModbusOut : std::uint8_t {
  kCommand = 0,        // set-point in the driver's unit (after [command])
  kEnable,             // driver enable, 1 = on
  kSafe,               // 1 while the firmware commands its safe state
  kEcho,               // the sensor_seq the command was computed from
  kHeartbeat,          // loop period count (low bits): changes every period while the loop runs
  kStatusSafe,         // firmware status: safe flag
  kStatusCauses,       // firmware status: active watchdog causes (bit i = cause i)
  kStatusOverruns,     // firmware status: loop overruns (not carried by the Modbus device: 0)
  kStatusSafeEntries,  // firmware status: normal -> safe transitions (not carried: 0)
  kStatusModelForce,   // live telemetry: the model's force of the period [N]
  kStatusDemand,       // live telemetry: the force demand of the period [N]
  kStatusCommand,      // live telemetry: the command voltage E of the period [V]
  kFaultReset,         // the driver's fault reset: 1 for one write (an edge) when the firmware
                       // is clean but for a latched driver fault, at most once per
                       // fault_reset_ms; else 0
};
inline constexpr std::size_t kNumModbusOut = 13;

struct ModbusPoint {
  bool mapped = false;
  std::uint8_t unit = 0;  // 1..247
  ModbusTable table = ModbusTable::kHolding;
  int address = 0;  // 0-based protocol address
  ModbusType type = ModbusType::kUint16;
  double scale = 1.0, offset = 0.0;
  bool swapped = false;  // 32-bit: low word at the lower address (the profile's word_order,
                         // or the point's own)
  int line = 0;          // where it was defined
  int request = -1;      // index into reads (inputs) or writes (outputs)
  int index = 0;         // offset in that request: registers, or bits for coils
  int count() const {    // registers (or bits) it takes
    return type == ModbusType::kInt32 || type == ModbusType::kUint32 || type == ModbusType::kFloat32
               ? 2
               : 1;
  }
};

// One request of a cycle.
struct ModbusRequest {
  std::uint8_t unit = 0;
  ModbusTable table = ModbusTable::kHolding;
  std::uint8_t function = 0;  // 0x01 0x02 0x03 0x04 (reads), 0x05 0x06 0x0F 0x10 (writes)
  int address = 0;
  int count = 0;  // registers or bits
};

// A fixed register (or coil) write the driver's manual asks for: at start-up (each new
// connection, before the first cycle; e.g. arming its communication watchdog) or periodically
// (e.g. the watchdog's keep-alive). Written with 0x06 (holding) or 0x05 (coil).
struct ModbusFixedWrite {
  std::uint8_t unit = 0;
  ModbusTable table = ModbusTable::kHolding;  // holding or coil
  int address = 0;
  std::uint16_t value = 0;  // raw register value (coil: 0 or 1)
  int period_ms = 0;        // periodic: 1..60000; start-up: 0
  int watchdog_ms = 0;      // periodic: the driver drops its coil when this write stops for
                            // watchdog_ms (> period_ms; 0: no watchdog on it)
  int line = 0;
  ModbusRequest request() const {
    return {unit, table, static_cast<std::uint8_t>(table == ModbusTable::kCoil ? 0x05 : 0x06),
            address, 1};
  }
};

struct ModbusProfile {
  static constexpr int kMaxGap = 8;  // registers (bits) a read bridges between points
  std::string path;
  std::uint64_t digest = 0;  // of the profile and its calibration (a reload compares)
  std::string name;
  bool swapped = false;       // 32-bit values: low word at the lower address
  int write_function = 16;    // 16 or 6
  bool align32 = false;       // 32-bit values at even addresses only
  int max_read = 125;         // registers per read (coils and discrete inputs: 2000)
  int fault_reset_ms = 1000;  // fault_reset: at most one edge per this time [ms]
  std::array<ModbusPoint, kNumCanIn> inputs{};
  std::array<ModbusPoint, kNumModbusOut> outputs{};
  std::vector<ModbusRequest> reads;        // grouped, in (unit, table, address) order
  std::vector<ModbusRequest> writes;       // the one carrying `command` last
  std::vector<ModbusFixedWrite> startup;   // in file order
  std::vector<ModbusFixedWrite> periodic;  // in file order
  std::string command_unit = "V";
  CommandMap command;
  const ModbusPoint& In(CanIn r) const { return inputs[static_cast<std::size_t>(r)]; }
  const ModbusPoint& Out(ModbusOut r) const { return outputs[static_cast<std::size_t>(r)]; }
  // Registers (or bits) the largest request needs.
  int MaxCount() const;
};

// Reads a profile file; false with *error "FILE:LINE: reason". Checks: every key known, roles
// known and mapped once, tables and types known (coils and discrete inputs are bits: no type),
// unit 1..247, address + count within 0..65535, no two roles sharing a register (bit) of a
// unit's table, 32-bit values at even addresses when align32, no 32-bit output with
// write_function 6, outputs only in writable tables (holding, coil), max_read within the
// function's limit (125 registers; 2000 bits for coils and discrete inputs), the [command]
// section (monotonic calibration, range); start-up and periodic writes in a writable table,
// not on a mapped role's register, a coil value 0 or 1, a register value 0..65535, period_ms
// 1..60000, watchdog_ms above period_ms and at most 60000.
bool LoadModbusProfile(const std::string& path, ModbusProfile* out, std::string* error);
// The same from text; `path` names it in errors and is the base of [command] calibration.
bool ParseModbusProfile(const std::string& text, const std::string& path, ModbusProfile* out,
                        std::string* error);
// True when the file is a TOML document with a [modbus] table (a Modbus profile, not a CAN
// one). Errors of any kind give false: the CAN loader then reports them.
bool IsModbusProfileFile(const std::string& path);

// ---- The codec (pure: no allocation, no exceptions, no I/O) ----

enum class ModbusReply : std::uint8_t { kOk = 0, kException, kMalformed };

// A read request's PDU (5 bytes).
int PutModbusRead(const ModbusRequest& r, std::uint8_t* pdu);
// Checks a read reply against its request (function, byte count, length).
ModbusReply CheckModbusRead(const ModbusRequest& r, const std::uint8_t* pdu, int len,
                            std::uint8_t* exception);
// A point's physical value from a checked read reply of its request. A float32 may be
// non-finite: the caller refuses it.
double ModbusPointValue(const ModbusProfile& p, const ModbusPoint& pt, const std::uint8_t* pdu);
// Writes a point's value into its write request's words (registers; coils: 0 or 1 per bit).
// false (nothing written) for a non-finite value or one its type cannot hold (never wrapped).
bool PutModbusPoint(const ModbusProfile& p, const ModbusPoint& pt, double value,
                    std::uint16_t* words);
// The same, for a server: a point's value into a table's storage (words indexed by address).
bool StoreModbusPoint(const ModbusProfile& p, const ModbusPoint& pt, double value,
                      std::uint16_t* table_words);
// A point's value from a table's storage (words indexed by address).
double LoadModbusPoint(const ModbusProfile& p, const ModbusPoint& pt,
                       const std::uint16_t* table_words);
// A write request's PDU from its words (0x05 0x06 0x0F 0x10).
int PutModbusWrite(const ModbusRequest& r, const std::uint16_t* words, std::uint8_t* pdu);
// Checks a write reply: the echo of address and count (0x0F 0x10) or of address and value
// (0x05 0x06).
ModbusReply CheckModbusWrite(const ModbusRequest& r, const std::uint8_t* request_pdu,
                             const std::uint8_t* pdu, int len, std::uint8_t* exception);

}  // namespace mrd::profile
