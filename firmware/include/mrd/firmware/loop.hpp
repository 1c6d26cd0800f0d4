#pragma once
// The control loop: wires a SensorSource and a CurrentDriver to the Controller at a fixed
// period with absolute deadlines. Per period, in order: read inputs, clamp dt, update, write,
// count time (and publish telemetry). Overruns skip the missed deadlines and are counted (in
// lockstep: a grant that jumps ahead, e.g. to a restarted firmware). A clock that halts (the
// lockstep GrantClock whose harness is gone) ends the run.
// The loop always leaves the driver in the safe state when it returns.

#include <atomic>
#include <cstdint>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io.hpp"
#include "mrd/firmware/period_hooks.hpp"
#include "mrd/firmware/telemetry.hpp"

namespace mrd::firmware {

class Loop {
 public:
  // All references outlive the loop. period_ns > 0.
  Loop(Clock& clock, SensorSource& source, CurrentDriver& driver, Controller& controller,
       Telemetry& telemetry, std::int64_t period_ns);
  Loop(const Loop&) = delete;
  Loop& operator=(const Loop&) = delete;

  // Runs periods until stop is set or duration_ns has elapsed (<= 0: until stop), then puts
  // the driver in the safe state. Real-time safe after entry (no allocation).
  void Run(const std::atomic<bool>& stop, std::int64_t duration_ns);
  // One period at the loop's time now_ns; the devices' wall time (IoTime) is now_ns on a
  // CLOCK_MONOTONIC clock, else CLOCK_MONOTONIC read once. Real-time safe.
  void Tick(std::int64_t now_ns);
  // One period at the time handed in (t.loop_ns is the loop's time). Real-time safe.
  void Tick(const IoTime& t);
  // Safe state on the driver (shutdown path), at the wall time read now or handed in.
  // Real-time safe.
  void Shutdown();
  void Shutdown(const IoTime& t);

  const TelemetrySnapshot& stats() const { return stats_; }
  // The controller running now (another one after a reload).
  const Controller& controller() const { return *controller_; }
  // Optional services (period_hooks.hpp); nullptr: none. Set before Run; they outlive the loop.
  void SetHook(PeriodHook* hook) { hook_ = hook; }
  void SetObserver(PeriodObserver* observer) { observer_ = observer; }

 private:
  Clock& clock_;
  SensorSource& source_;
  CurrentDriver& driver_;
  Controller* controller_;  // a reload (PeriodHook) swaps it at a period boundary
  // Counters of the controllers swapped out (a reload), so the totals run on.
  std::uint64_t base_model_resets_ = 0;
  std::uint64_t base_input_excursions_ = 0;
  std::uint64_t base_force_excursions_ = 0;
  WatchdogCounters base_watchdog_;
  Telemetry& telemetry_;
  std::int64_t period_ns_;
  std::int64_t last_tick_ns_ = 0;
  bool first_tick_ = true;
  bool driver_fault_ = false;
  SensorFrame frame_;
  TelemetrySnapshot stats_;
  PeriodHook* hook_ = nullptr;
  PeriodObserver* observer_ = nullptr;
  PeriodRecord record_;
  bool in_run_ = false;  // Run publishes the record after timing the period; a bare Tick at once
};

}  // namespace mrd::firmware
