#pragma once
// A field device: one bus (CAN, Modbus or GPIO) with the signals and outputs routed to it.
// FieldbusIo (fieldbus_io.hpp) puts a set of them behind the loop's SensorSource and
// CurrentDriver, so the loop and the controller cannot tell buses from the simulated damper.
//
// Lifecycle (in the spirit of ros2_control's hardware interface), outside the tick:
//   Configure   open file descriptors, allocate, check settings          start-up, may block
//   Activate    start I/O threads; outputs stay in their safe state        start-up
//   Read/Write  every period: copy memory or bounded non-blocking I/O     real-time safe
//   Deactivate  outputs to the safe state (0 V, enable low), threads down  shutdown, may block
// Recovery from a lost peer (reconnect, reopen) is each device's own business, off the tick
// or rate-limited within it, and is counted (DeviceCounters::reconnects). A read or write that
// fails says why (IoError); the loop turns a faulted device into its bus's watchdog cause.

#include <cstdint>
#include <string>

#include "mrd/firmware/io.hpp"
#include "mrd/firmware/io/io_config.hpp"
#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {

class TimeGrantSource;  // grant_clock.hpp

// Why a read or write failed.
enum class IoError : std::uint8_t {
  kNone = 0,
  kTimeout,        // no reply / no frame within its deadline
  kCrc,            // checksum or CRC mismatch
  kDisconnected,   // peer or bus gone (socket closed, serial line down)
  kBusOff,         // CAN controller bus-off / error passive
  kRejectedFrame,  // wrong DLC, unknown ID, stale or repeated rolling counter
  kBadValue,       // out of range or non-finite value in a well-formed message
  kException,      // Modbus exception response
  kOverflow,       // queue or socket buffer full: data dropped
  kSystem,         // other system call failure (errno in the device's log at start-up)
};
inline constexpr std::size_t kNumIoErrors = 10;

// Static name ("none", "timeout", "crc", "disconnected", "bus_off", "rejected_frame",
// "bad_value", "exception", "overflow", "system").
const char* IoErrorName(IoError error);

// What the loop sends each period.
struct DriverCommand {
  double volts = 0.0;      // [V], within [E_min, E_max] (the safe voltage when safe)
  bool enable = false;     // driver enable line / bit
  bool safe = true;        // the safe state is commanded
  std::uint64_t tick = 0;  // period count since start (heartbeats derive their toggling)
};

// Per device; updated by the device's own thread(s) or the tick, read by anyone (copies).
struct DeviceCounters {
  std::uint64_t rx_ok = 0;                  // frames / replies / edges accepted
  std::uint64_t rx_rejected = 0;            // rejected (why: errors[])
  std::uint64_t tx_ok = 0;                  // frames / writes sent
  std::uint64_t tx_failed = 0;              // not sent (why: errors[])
  std::uint64_t reconnects = 0;             // successful recoveries after kDisconnected
  std::uint64_t errors[kNumIoErrors] = {};  // count per IoError
  IoError last_error = IoError::kNone;
};

class BusDevice {
 public:
  BusDevice() = default;
  virtual ~BusDevice() = default;
  BusDevice(const BusDevice&) = delete;
  BusDevice& operator=(const BusDevice&) = delete;

  virtual const char* name() const = 0;        // "can", "modbus", "gpio"
  virtual FaultCause fault_cause() const = 0;  // the watchdog cause of this bus
  // A failed write is this bus's fault too (fault_cause() at the next Read, besides the
  // loop's driver_fault): a Modbus transaction refused or lost, a PWM sysfs write that failed.
  // Not CAN's: its write also fails when the tick came too late to act on its sample.
  virtual bool write_faults_are_bus_faults() const { return false; }

  // Start-up. false with *error = reason (e.g. "can: cannot open can0: No such device").
  virtual bool Configure(std::string* error) = 0;
  virtual bool Activate(std::string* error) = 0;
  // Shutdown: safe outputs, stop threads. Idempotent.
  virtual void Deactivate() = 0;

  // t: the period's time (io.hpp IoTime); deadlines, timeouts and schedules on the tick run
  // on t.wall_ns (CLOCK_MONOTONIC) instead of a clock read of their own.
  // Merges the latest samples of the routed inputs into *frame, each with its own sample
  // stamp (CLOCK_MONOTONIC [ns]; granted time in lockstep); leaves the other fields alone.
  // kNoData: nothing new; kFault: *why says why (stale samples keep their old stamps).
  // Real-time safe.
  virtual IoStatus Read(const IoTime& t, SensorFrame* frame, IoError* why) = 0;
  // Sends the routed outputs of cmd. Real-time safe, never waits on the bus.
  virtual IoStatus Write(const IoTime& t, const DriverCommand& cmd, IoError* why) = 0;
  // Status output (if routed here), at the device's own rate. Real-time safe.
  virtual void PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) {
    (void)t;
    (void)stats;
  }

  virtual DeviceCounters counters() const = 0;
  // The loop's time grants when this device carries them (lockstep); else nullptr.
  virtual TimeGrantSource* grant_source() { return nullptr; }
};

}  // namespace mrd::firmware
