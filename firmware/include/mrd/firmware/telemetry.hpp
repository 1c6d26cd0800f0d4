#pragma once
// Telemetry out of the real-time loop without locks or allocation: the loop publishes a
// snapshot every period through a seqlock (wait-free); any thread reads the latest one.

#include <cstdint>

#include "mrd/firmware/seqlock.hpp"
#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {

struct TelemetrySnapshot {
  std::uint64_t ticks = 0;
  std::uint64_t overruns = 0;         // periods whose work ended past the next deadline
  std::uint64_t missed_periods = 0;   // deadlines skipped after overruns
  std::int64_t worst_latency_ns = 0;  // wake-up minus deadline, worst
  std::int64_t worst_exec_ns = 0;     // work per period, worst
  std::int64_t last_exec_ns = 0;
  std::uint64_t read_faults = 0;
  std::uint64_t write_faults = 0;
  // Force laws (inverter.hpp): periods whose demand was 0 or of the sign opposite to v (E_min
  // by rule); whose other demand was out of the model's reach (the nearest force commanded);
  // whose model was not monotone in E over [E_min, E_max] at the period's state.
  std::uint64_t passive_demands = 0;
  std::uint64_t unreachable = 0;
  std::uint64_t non_monotone = 0;
  std::uint64_t model_resets = 0;
  std::uint64_t envelope_excursions = 0;  // periods with v or x held to the envelope
  std::uint64_t force_excursions = 0;     // periods with the model force held to its envelope
  WatchdogCounters watchdog;
  std::uint32_t active_causes = 0;
  bool safe = true;
  double last_command_v = 0.0;
  double model_force_n = 0.0;
  double force_demand_n = 0.0;
  double measured_force_n = 0.0;  // NaN when no force sensor
  // Sums for RMS figures over periods with a measured force (not in the safe state).
  std::uint64_t force_samples = 0;
  double sum_sq_model_error = 0.0;  // (model - measured)^2 [N^2]
  std::uint64_t tracking_samples = 0;
  double sum_sq_tracking_error = 0.0;  // (demand - measured)^2 [N^2], force laws
};

using Telemetry = Seqlock<TelemetrySnapshot>;

}  // namespace mrd::firmware
