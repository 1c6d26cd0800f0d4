#pragma once
// Narrow I/O interfaces between the control loop and the buses (FieldbusIo, in mrd::firmware_io,
// implements them over the devices of mrd/firmware/io/bus_device.hpp; SimulatedDamper for dry
// runs and tests). Every call is real-time safe in every implementation: no allocation, no
// exceptions, no blocking beyond a bounded bus transaction; failures come back as IoStatus.

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "mrd/firmware/signals.hpp"  // Input, kNumInputs, Bit(Input)

namespace mrd::firmware {

enum class IoStatus : std::uint8_t {
  kOk = 0,
  kNoData,  // nothing new this period (not an error by itself; ages tell staleness)
  kFault,   // bus or device fault
};

// Latest value of one signal and when it was sampled (CLOCK_MONOTONIC [ns]).
struct Stamped {
  double value = std::numeric_limits<double>::quiet_NaN();
  std::int64_t stamp_ns = std::numeric_limits<std::int64_t>::min();  // never sampled
};

// What the sensors delivered, latest values, indexed by Input: frame[Input::kVelocity].
//   kVelocity          relative damper velocity [cm/s]
//   kDisplacement      relative damper displacement [cm]
//   kDemand            force demand [N]
//   kBodyVelocity      absolute body velocity [cm/s] (skyhook)
//   kForce             measured damper force [N] (test rigs only; telemetry)
//   kBodyAcceleration  absolute body acceleration [cm/s^2] (ADD, SH-ADD)
//   kWheelVelocity     absolute wheel (unsprung) velocity [cm/s] (groundhook, hybrid)
//   kFloorAcceleration1..3  absolute floor accelerations [m/s^2] (clipped-optimal)
// Validity is the stamp: an input no source set keeps stamp_ns == min (valid() false; the
// watchdog only checks the inputs the configuration needs). kFaultLine's slot stays unused:
// the fault line is the flag fault_line, which every source ORs in.
struct SensorFrame {
  std::array<Stamped, kNumInputs> inputs{};
  bool fault_line = false;  // external fault input asserted
  // Another damper channel of the loop faulted (FaultPolicy::kAll, loop.hpp): set by the loop
  // before the update, never by a source.
  bool peer_fault = false;
  // Watchdog::Bit(FaultCause::kCanBus / kModbusBus / kGpioBus) of each bus whose device
  // faulted this period (0 from sources that name no bus).
  std::uint32_t bus_faults = 0;

  Stamped& operator[](Input i) { return inputs[static_cast<std::size_t>(i)]; }
  const Stamped& operator[](Input i) const { return inputs[static_cast<std::size_t>(i)]; }
  bool valid(Input i) const {
    return (*this)[i].stamp_ns != std::numeric_limits<std::int64_t>::min();
  }
};

// Input::kFloorAcceleration1 + i, i in 0..2.
constexpr Input FloorAcceleration(int i) {
  return static_cast<Input>(static_cast<int>(Input::kFloorAcceleration1) + i);
}

// The merge every field device does in Read: each input routed to it (its Bit(Input) set in
// routed), kFaultLine excepted, takes value_of(input) (a Stamped); the other inputs are left
// alone (another device serves them). Real-time safe.
template <typename ValueOf>
void MergeRouted(std::uint32_t routed, SensorFrame* frame, ValueOf&& value_of) {
  for (std::size_t i = 0; i < kNumInputs; ++i) {
    const auto input = static_cast<Input>(i);
    if (input == Input::kFaultLine || (routed & Bit(input)) == 0) continue;
    (*frame)[input] = value_of(input);
  }
}

struct TelemetrySnapshot;

// The period's time, handed in by the loop (read once per period, as ros2_control's
// read(time, period)). Two clocks, never mixed:
//   loop_ns  the loop's clock [ns]: the period's time (the harness-granted simulated time in
//            lockstep runs; CLOCK_MONOTONIC otherwise)
//   wall_ns  CLOCK_MONOTONIC [ns], for the devices' send deadlines, reply timeouts, backoffs
//            and wall-clock sample stamps (equal to loop_ns when the loop runs on CLOCK_MONOTONIC)
// The devices' own I/O threads (Modbus worker, reconnects) keep reading the clock themselves.
struct IoTime {
  std::int64_t loop_ns = 0;
  std::int64_t wall_ns = 0;
};

class SensorSource {
 public:
  virtual ~SensorSource() = default;
  // Fills *frame with the latest values at the period's time t. kFault: the frame may be
  // partial. Real-time safe.
  virtual IoStatus Read(const IoTime& t, SensorFrame* frame) = 0;
};

class CurrentDriver {
 public:
  virtual ~CurrentDriver() = default;
  // Commands the coil voltage [V] at the period's time t. Real-time safe.
  virtual IoStatus Command(const IoTime& t, double volts) = 0;
  // Puts the driver in its safe state at safe_volts [V] (e.g. 0 V, or disabled). Must
  // succeed whenever the hardware can; also used at shutdown. Real-time safe.
  virtual IoStatus EnterSafeState(const IoTime& t, double safe_volts) = 0;
  // The loop's counters after each period (status frames, registers). Real-time safe; must
  // not block (a driver sends at its own lower rate). Default: nothing to publish.
  virtual void PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) {
    (void)t;
    (void)stats;
  }
};

// Time source of the loop: CLOCK_MONOTONIC with absolute sleeps on a target, or a lockstep
// clock that jumps to the deadline (dry runs and tests, no sleeping).
class Clock {
 public:
  virtual ~Clock() = default;
  virtual std::int64_t Now() = 0;  // [ns]
  // Sleeps until the absolute time t_ns (returns at once when it has passed). Real-time safe.
  virtual void SleepUntil(std::int64_t t_ns) = 0;
  // True once time can no longer advance (a lockstep clock whose harness is gone): the loop
  // then ends instead of ticking.
  virtual bool Halted() const { return false; }
  // True when Now() is CLOCK_MONOTONIC itself: the loop then hands Now() in as the wall time
  // too (IoTime) instead of reading the clock a second time.
  virtual bool IsMonotonic() const { return false; }
};

// CLOCK_MONOTONIC; SleepUntil uses clock_nanosleep(TIMER_ABSTIME) and resumes after signals.
class MonotonicClock final : public Clock {
 public:
  std::int64_t Now() override;
  void SleepUntil(std::int64_t t_ns) override;
  bool IsMonotonic() const override { return true; }
};

// Simulated time: SleepUntil jumps there. Starts at start_ns.
class LockstepClock final : public Clock {
 public:
  explicit LockstepClock(std::int64_t start_ns = 0) : now_(start_ns) {}
  std::int64_t Now() override { return now_; }
  void SleepUntil(std::int64_t t_ns) override { now_ = t_ns > now_ ? t_ns : now_; }
  void Advance(std::int64_t dt_ns) { now_ += dt_ns; }

 private:
  std::int64_t now_;
};

}  // namespace mrd::firmware
