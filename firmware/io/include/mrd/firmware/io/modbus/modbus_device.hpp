#pragma once
// The Modbus field device: a Modbus TCP or RTU client for the register map of
// docs/modbus_registers.md (mrd/protocol/modbus_map.hpp).
//
// Why a worker thread and not the tick, what it reads and writes each cycle, the latest block
// at once, failures and their counters, retries, reconnects, backoff, stopping and lockstep:
// docs/modbus_registers.md ("Timing", "Errors and counters", the grant register), the one
// place; keep it current with this code.
//
// With a device profile (config.modbus_profile, [modbus] profile; docs/devices.md) the worker
// runs the profile's requests instead of the built-in map's two blocks (same worker, waits,
// retries, reconnects and wake-ups; src/modbus_device_profile.cpp): each cycle it writes the
// profile's write requests (each to its unit id, the one carrying the command last) and reads
// its grouped read requests; a cycle's sample is published only when every read succeeded.
// The set-point goes through the profile's CommandMap on the loop's Write (slew per control
// period; the safe state is not rate-limited). A decoded value that is not finite is
// bad_value (the read fails: safe state); a set-point or value the register cannot hold makes
// that write a safe one (set-point 0, enable 0, safe 1) and counts bad_value. With sensor_seq
// mapped, a repeated seq is not new data; without it every good read is. driver_faults
// non-zero sets the fault line whether [modbus] inputs routes fault_line or not (as on CAN);
// a refused write does not end the cycle (the rest goes out with the safe values). Activate waits
// (bounded) for the first cycle's sample or failure, so the loop does not start on a never-sampled
// frame (whose values are NaN: a non_finite trip at start-up). On every new connection the
// profile's start-up writes go out first (one refused at start-up is a start-up error naming
// its register); its periodic writes go out in the worker's cycle when due. fault_reset: 1 in
// one write while the driver reports a fault and the firmware has no other cause, at most once
// per fault_reset_ms (a latched driver fault is reset without a power cycle).

#include <pthread.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/io/fault_reset.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/seqlock.hpp"
#include "mrd/profile/command_map.hpp"

namespace mrd::profile {
struct ModbusProfile;
struct ModbusFixedWrite;
}  // namespace mrd::profile

namespace mrd::firmware {

class ModbusLink;

class ModbusDevice final : public BusDevice, public TimeGrantSource {
 public:
  explicit ModbusDevice(const ModbusConfig& config);
  ~ModbusDevice() override;

  const char* name() const override { return "modbus"; }
  FaultCause fault_cause() const override { return FaultCause::kModbusBus; }
  bool write_faults_are_bus_faults() const override { return true; }
  // Creates the link and tries a first connection (a peer not up yet is not an error: the
  // worker keeps trying and the loop stays safe meanwhile).
  bool Configure(std::string* error) override;
  // Starts the worker thread.
  bool Activate(std::string* error) override;
  // Stops the worker, writes the safe command block (0 V, enable off) once on a link that is
  // up (one attempt, at most one response timeout), closes the link.
  void Deactivate() override;

  IoStatus Read(const IoTime& t, SensorFrame* frame, IoError* why) override;
  IoStatus Write(const IoTime& t, const DriverCommand& cmd, IoError* why) override;
  void PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) override;
  DeviceCounters counters() const override;
  bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) override;
  TimeGrantSource* grant_source() override { return config_.lockstep ? this : nullptr; }

 private:
  // What the worker hands to the loop.
  struct Sample {
    std::uint64_t accepted = 0;  // sensor blocks accepted so far (changes: new data)
    std::int64_t stamp_ns = 0;   // CLOCK_MONOTONIC when its request was sent (lockstep: grant)
    std::uint32_t seq = 0;
    std::int64_t grant_ns = 0;  // lockstep: the latest granted time (0: none yet)
    // Per Input (SensorFrame's units); body and wheel, floor accelerations: profile only.
    std::array<double, kNumInputs> values{};
    bool fault_line = false;    // the fault_line input (counts when routed)
    bool driver_fault = false;  // the driver reports a fault (driver_faults; always counts)
    double& value(Input i) { return values[static_cast<std::size_t>(i)]; }
    bool read_failed = false;   // the latest sensor read (after retries) failed
    bool write_failed = false;  // the latest command write (after retries) failed
    IoError why = IoError::kNone;
  };
  // What the loop hands to the worker.
  struct Command {
    std::uint64_t tick = 0;
    double volts = 0.0;
    double setpoint = 0.0;  // profile: after the CommandMap (driver's unit)
    bool enable = false;
    bool safe = true;
    std::uint32_t echo = 0;
  };
  enum class Outcome : std::uint8_t { kOk, kFailed, kAbandoned, kNothing };
  class Waker;  // the link's Interrupt (modbus_device.cpp)

  // How one worker cycle ended: kDone (transactions made, wait for the next one), kNoSession
  // (no connection yet: backoff), kSessionEnded (link broken or timing out: reconnect),
  // kAbandoned (a safe block is pending: start the next cycle at once).
  enum class CycleEnd : std::uint8_t { kDone, kNoSession, kSessionEnded, kAbandoned };

  static void* WorkerMain(void* self);
  void Work();  // WorkPolling, or WorkLockstep with config_.lockstep
  // Polling: one cycle every poll_period (no catch-up burst when behind); a safe block at once.
  void WorkPolling();
  // Lockstep: cycles as grants come; after a new grant, waits for the loop's command of it.
  void WorkLockstep();
  // One cycle: connect (or wait for the backoff), write the latest command, read the sensors
  // (*new_grant: a new time grant was read), publish the sample; counts cycles that timed out.
  CycleEnd Cycle(Sample* s, int* timed_out_cycles, bool* new_grant);
  // Waits for the next connection attempt; true when connected.
  bool Connect(Sample* s);
  void EndSession();
  // The worker's transactions (with retries); on failure s->why and the counters say why.
  Outcome WriteLatest(Sample* s);
  Outcome ReadSensors(Sample* s, bool* new_grant);
  // Lockstep: a block read before the first grant belongs to no step (whether the worker reads
  // one depends on when it connected): true, and the read counts as good but not as data.
  // Both reads (the register map's and a profile's) apply it once the grant is decoded.
  bool BeforeFirstGrant(Sample* s) const;
  // One write of c (one attempt). why: set on failure.
  Outcome WriteOnce(const Command& c, IoError* why, bool interruptible);
  // One read request (one attempt, the link's unit): the quiet-line wait a failed exchange
  // asked for, the stop check, the exchange. *stamp_ns: what the reply's values are no older
  // than. kOk: a reply of *reply_len bytes; kFailed: *why (not counted yet).
  Outcome ReadOnce(const std::uint8_t* pdu, int len, std::uint8_t* reply, int* reply_len,
                   IoError* why, std::int64_t* stamp_ns);
  // The profile's transactions (modbus_device_profile.cpp).
  Outcome ReadProfile(Sample* s, bool* new_grant);
  Outcome WriteProfileOnce(const Command& c, IoError* why, bool interruptible);
  // The profile's start-up writes on a new connection (retried as any request); false when one
  // failed (refused: startup_refused_ names it for Activate).
  bool StartUpWrites(Sample* s);
  // The profile's periodic writes that are due (one attempt each; a failure fails the cycle's
  // write, the loop goes safe).
  void PeriodicWrites(Sample* s);
  // One fixed write (0x05 / 0x06), one attempt. *exception: the device's code when refused.
  bool WriteFixed(const profile::ModbusFixedWrite& w, IoError* why, std::uint8_t* exception);
  bool LatestCommand(Command* c) const;
  // The loop posted a safe block since the latest block written was a driven one.
  bool SafePending() const;
  // Counts a failed attempt (reply_refused: a reply came and was refused, rx_rejected).
  void Failed(IoError e, bool reply_refused);
  void Count(IoError e);
  void GoodExchange();  // a complete exchange on this connection: the backoff restarts

  ModbusConfig config_;
  const profile::ModbusProfile* profile_ = nullptr;  // config_.modbus_profile (null: built-in)
  profile::CommandMap command_map_;                  // loop side: E -> set-point
  double safe_setpoint_ = 0.0;                       // set-point of the safe state
  std::unique_ptr<std::uint16_t[]> words_;           // worker: one write request's words
  std::unique_ptr<std::int64_t[]> periodic_due_;     // worker: next time of each periodic write
  bool started_ = false;                             // worker: start-up writes done this session
  bool driver_fault_seen_ = false;                   // worker: the latest good read's driver_faults
  FaultResetRule reset_rule_;                        // worker: the fault_reset edges
  // A start-up write the device refused: its index + 1 (0: none) and exception code.
  std::atomic<int> startup_refused_{0};
  std::atomic<std::uint8_t> startup_exception_{0};
  std::unique_ptr<ModbusLink> link_;
  std::unique_ptr<Waker> waker_;
  bool configured_ = false;
  pthread_t thread_{};
  bool thread_started_ = false;
  std::atomic<bool> running_{false};

  // Wake-ups (eventfds): loop/Deactivate -> worker (a safe block posted, lockstep status, stop),
  // worker -> WaitGrant (lockstep).
  int wake_ = -1;
  int grant_event_ = -1;

  Seqlock<Sample> sample_;
  Seqlock<Command> command_;
  std::atomic<std::uint16_t> status_causes_{0};
  // False until the firmware's first PublishStatus: no fault reset before its causes are known.
  std::atomic<bool> causes_known_{false};
  // Live telemetry of the last published period (profile roles status_model_force, _demand,
  // _command) [N], [N], [V].
  std::atomic<double> status_model_force_{0.0}, status_demand_{0.0}, status_command_{0.0};
  std::atomic<std::uint32_t> status_ticks_{0};

  // Worker side.
  bool resync_ = false;                   // RTU: wait for a quiet line before the next request
  std::int64_t unanswered_since_ns_ = 0;  // RTU: a read sent then that may be answered late
  bool timed_out_ = false;                // a transaction of this cycle timed out (link suspect)
  bool session_good_ = false;             // this connection carried a good exchange
  bool any_written_ = false;
  std::uint64_t written_tick_ = 0;
  bool written_safe_ = true;                  // the latest block written was a safe one
  bool writing_safe_ = false;                 // the write in flight carries the safe state
  bool safe_acknowledged_ = false;            // the last acknowledged block was a safe one...
  std::uint64_t safe_acknowledged_tick_ = 0;  // ...of this tick
  bool have_seq_ = false;
  std::int64_t backoff_ns_ = 0;
  std::int64_t connect_at_ns_ = 0;

  // Loop side (tick thread only).
  Sample cached_;  // latest sample copied out of sample_
  std::uint64_t seen_accepted_ = 0;
  std::uint32_t last_seq_ = 0;
  bool last_write_failed_ = false;
  bool posted_safe_ = true;  // the latest command posted was a safe one
  // Lockstep: the tick of the last command the worker wrote or failed to write (worker side).
  std::atomic<std::uint64_t> handled_tick_{0};
  std::atomic<bool> handled_any_{false};
  // Lockstep: one past the tick of the last command followed by PublishStatus (0: none yet;
  // written by the loop, read by the worker). The worker writes only ticks below it (the
  // published ones). The shutdown's safe block, posted after the last PublishStatus, is
  // Deactivate's alone: whether the worker would have got to it before it stopped depends on
  // wall time, the request count must not.
  std::atomic<std::uint64_t> released_tick_{0};
  std::int64_t granted_ns_ = 0;  // the latest grant WaitGrant returned
  IoError last_why_ = IoError::kNone;

  // Counters, written by the worker, read by anyone.
  std::atomic<std::uint64_t> rx_ok_{0}, rx_rejected_{0}, tx_ok_{0}, tx_failed_{0}, reconnects_{0};
  std::atomic<std::uint64_t> errors_[kNumIoErrors] = {};
  std::atomic<std::uint8_t> last_error_{0};
  bool ever_connected_ = false;
};

}  // namespace mrd::firmware
