#pragma once
// One damper channel of the loop (loop.hpp): its sensors, its driver, its controller, its
// counters and its period record. The loop runs every channel on one clock and one period:
//
//   Begin   the period boundary (a pending parameter change or reload), then read the inputs
//   (the loop's body law may set inputs of every channel here: force demands)
//   Finish  update, write (a failed command falls back to the safe state at once), count,
//           publish the telemetry and the period's record
//
// A channel knows of the others only through peer_fault (FaultPolicy::kAll): the frame's
// peer_fault raises the controller's other_channel cause, so the channel goes safe with the
// reason counted as its own. Everything here is real-time safe: no allocation, no exceptions.

#include <cstdint>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io.hpp"
#include "mrd/firmware/period_hooks.hpp"
#include "mrd/firmware/telemetry.hpp"

namespace mrd::firmware {

// The loop's timing, shared by its channels (each channel's telemetry carries a copy).
struct LoopTiming {
  std::uint64_t overruns = 0;
  std::uint64_t missed_periods = 0;
  std::int64_t worst_latency_ns = 0;
  std::int64_t worst_exec_ns = 0;
  std::int64_t last_exec_ns = 0;
};

class Channel {
 public:
  // All references outlive the channel.
  Channel(SensorSource& source, CurrentDriver& driver, Controller& controller,
          Telemetry& telemetry);
  Channel(const Channel&) = delete;
  Channel& operator=(const Channel&) = delete;

  // Optional services (period_hooks.hpp); nullptr: none. Set before the loop runs.
  void SetHook(PeriodHook* hook) { hook_ = hook; }
  void SetObserver(PeriodObserver* observer) { observer_ = observer; }

  // The period boundary at io.loop_ns (hook, reload), then the read into frame().
  void Begin(const IoTime& io);
  // The frame read by Begin; a body law may set inputs before Finish.
  SensorFrame& frame() { return frame_; }
  // Update on frame() (dt_s: the clamped period [s]; peer_fault: another channel's fault puts
  // this one safe), write, count, publish. defer_record: the record waits for PublishRecord
  // (the loop's Run, once the period's timing is known); else the observer gets it now.
  void Finish(const IoTime& io, double dt_s, bool peer_fault, const LoopTiming& timing,
              bool defer_record);
  // The deferred record with the period's timing.
  void PublishRecord(std::int64_t latency_ns, std::int64_t exec_ns);
  // Safe state on the driver (shutdown path). Real-time safe.
  void Shutdown(const IoTime& t, const LoopTiming& timing);

  // The causes of the last period other than other_channel (the fault this channel passes on
  // to the others under FaultPolicy::kAll).
  std::uint32_t own_causes() const;
  const TelemetrySnapshot& stats() const { return stats_; }
  // The controller running now (another one after a reload).
  const Controller& controller() const { return *controller_; }

 private:
  void Count(const ControllerOutput& out, const LoopTiming& timing);
  void Record(const IoTime& io, const ControllerOutput& out, IoStatus write);

  SensorSource& source_;
  CurrentDriver& driver_;
  Controller* controller_;  // a reload (PeriodHook) swaps it at a period boundary
  Telemetry& telemetry_;
  // Counters of the controllers swapped out (a reload), so the totals run on.
  std::uint64_t base_model_resets_ = 0;
  std::uint64_t base_input_excursions_ = 0;
  std::uint64_t base_force_excursions_ = 0;
  WatchdogCounters base_watchdog_;
  bool driver_fault_ = false;
  IoStatus read_ = IoStatus::kOk;
  SensorFrame frame_;
  TelemetrySnapshot stats_;
  PeriodHook* hook_ = nullptr;
  PeriodObserver* observer_ = nullptr;
  PeriodRecord record_;
};

}  // namespace mrd::firmware
