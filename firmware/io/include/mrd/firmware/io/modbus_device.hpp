#pragma once
// The Modbus field device: a libmodbus client (TCP or RTU) for the register map of
// docs/modbus_registers.md (mrd/protocol/modbus_map.hpp).
//
// Why a worker thread and not non-blocking I/O in the tick: libmodbus 3.1.6 blocks in every
// transaction until the reply or the response timeout, and an RTU read of the sensor block
// takes about 2 ms on a 115200 Bd line, longer than the 1 ms period. So one thread per device
// owns the modbus_t: each poll_period it writes the latest posted command block (one 0x10
// request, only when the loop posted a new one) and reads the sensor block (one 0x03
// request), stamps the sample with CLOCK_MONOTONIC when the reply arrived, and publishes it
// through a seqlock. The tick only copies memory: Read takes the latest sample (a bounded
// number of seqlock attempts, kNoData if the worker is mid-write every time), Write posts the
// command into another seqlock. Nothing on the tick allocates, locks or waits on the bus.
//
// Failures (per attempt, counted in errors[]): timeout (no reply within response_timeout),
// crc (RTU), exception (the server answered with a Modbus exception), rejected_frame (reply
// malformed, wrong slave/function), bad_value (reserved fault bits set), disconnected (reset,
// refused, EIO on the serial line). A timeout or CRC error is retried `retries` times in the
// same cycle. After a disconnect, or 3 failed cycles in a row, the worker closes the link and
// reconnects with backoff (5 ms doubling to 200 ms), counting reconnects. While the latest
// transaction failed, Read reports kFault with the reason (the loop raises the modbus_bus
// watchdog cause) and the sample stamps age, so the stale-sensor cause trips as well. A sensor
// block whose seq did not change since the last accepted one is not new data (a frozen server
// goes stale).
//
// Lockstep (config.lockstep: [loop] clock = "grant" and no [can] bus): the device is the loop's
// TimeGrantSource. The worker reads the sensor block and the grant register in one request
// (kLockstepSensorCount registers) back to back; a read that brings a new grant publishes the
// sample stamped with the granted time and wakes WaitGrant (an eventfd); the worker then waits
// (eventfd, bounded) for the loop's tick to post its command and status (PublishStatus) and
// writes them at once, so the harness receives one command block per grant, carrying that
// tick's status. WaitGrant that times out is a missed grant: the next Read reports kFault
// (timeout) and the loop commands the safe state, as on CAN.

#include <pthread.h>

#include <atomic>
#include <cstdint>
#include <string>

#include "mrd/firmware/bus_device.hpp"
#include "mrd/firmware/grant_clock.hpp"
#include "mrd/firmware/seqlock.hpp"

typedef struct _modbus modbus_t;  // NOLINT: libmodbus's own name

namespace mrd::firmware {

class ModbusDevice final : public BusDevice, public TimeGrantSource {
 public:
  explicit ModbusDevice(const ModbusConfig& config);
  ~ModbusDevice() override;

  const char* name() const override { return "modbus"; }
  FaultCause fault_cause() const override { return FaultCause::kModbusBus; }
  // Creates the libmodbus context and tries a first connection (a peer not up yet is not an
  // error: the worker keeps trying and the loop stays safe meanwhile).
  bool Configure(std::string* error) override;
  // Starts the worker thread.
  bool Activate(std::string* error) override;
  // Stops the worker, writes the safe command block (0 V, enable off) once, closes the link.
  void Deactivate() override;

  IoStatus Read(SensorFrame* frame, IoError* why) override;
  IoStatus Write(const DriverCommand& cmd, IoError* why) override;
  void PublishStatus(const TelemetrySnapshot& stats) override;
  DeviceCounters counters() const override;
  bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) override;
  TimeGrantSource* grant_source() override { return config_.lockstep ? this : nullptr; }

 private:
  // What the worker hands to the loop.
  struct Sample {
    std::uint64_t accepted = 0;  // sensor blocks accepted so far (changes: new data)
    std::int64_t stamp_ns = 0;   // CLOCK_MONOTONIC when the latest accepted reply arrived
    std::uint32_t seq = 0;
    std::int64_t grant_ns = 0;  // lockstep: the latest granted time (0: none yet)
    double velocity = 0.0, displacement = 0.0, demand = 0.0, body_velocity = 0.0, force = 0.0;
    bool fault_line = false;
    bool read_failed = false;   // the latest sensor read (after retries) failed
    bool write_failed = false;  // the latest command write (after retries) failed
    IoError why = IoError::kNone;
  };
  // What the loop hands to the worker.
  struct Command {
    std::uint64_t tick = 0;
    double volts = 0.0;
    bool enable = false;
    bool safe = true;
    std::uint32_t echo = 0;
  };

  static void* WorkerMain(void* self);
  void Work();
  bool Connect();
  void Disconnect();
  // One transaction with retries; true on success, else *why (counted).
  bool ReadSensors(std::uint16_t* regs, int count, IoError* why);
  bool WriteCommand(const Command& c, IoError* why);
  void Resync();  // after a failed exchange: discard input until the line is quiet
  void Count(IoError e);

  ModbusConfig config_;
  modbus_t* ctx_ = nullptr;
  bool connected_ = false;
  bool resync_ = false;  // a transaction failed: wait for a quiet line before the next one
  bool ever_connected_ = false;
  pthread_t thread_{};
  bool thread_started_ = false;
  std::atomic<bool> running_{false};

  // Lockstep wake-ups (eventfds, -1 otherwise): worker -> WaitGrant, loop -> worker.
  int grant_event_ = -1;
  int command_event_ = -1;

  Seqlock<Sample> sample_;
  Seqlock<Command> command_;
  std::atomic<std::uint16_t> status_causes_{0};
  std::atomic<std::uint32_t> status_ticks_{0};

  // Loop side (tick thread only).
  Sample cached_;  // latest sample copied out of sample_
  std::uint64_t seen_accepted_ = 0;
  std::uint32_t last_seq_ = 0;
  bool last_write_failed_ = false;
  std::int64_t granted_ns_ = 0;   // the latest grant WaitGrant returned
  IoError last_why_ = IoError::kNone;

  // Counters, written by the worker, read by anyone.
  std::atomic<std::uint64_t> rx_ok_{0}, rx_rejected_{0}, tx_ok_{0}, tx_failed_{0}, reconnects_{0};
  std::atomic<std::uint64_t> errors_[kNumIoErrors] = {};
  std::atomic<std::uint8_t> last_error_{0};
};

}  // namespace mrd::firmware
