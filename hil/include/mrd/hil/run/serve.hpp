#pragma once
// The harness's real-time plant loop: every period it hears the firmware through the ports,
// applies the command through the simulated current driver, steps the reference damper plant
// and publishes its sensors on every port.
//
// Simulated current driver: applied voltage = received set-point while the driver is enabled
// (when some port carries an enable) and the firmware's heartbeat is fresh (when some port
// carries one); otherwise 0 V (the coil's safe state). Every received set-point is checked
// against the invariant "finite and within [0, E_max]"; violations are counted, and the
// driver clamps what it applies.

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/sim/damper_plant.hpp"

namespace mrd::hil {

struct ServeOptions {
  SpencerParams params;
  PlantExcitation excitation;
  double period_s = 1e-3;
  double duration_s = 5.0;            // <= 0: until stop
  double e_max = 2.25;                // [V], the invariant's upper bound
  double heartbeat_timeout_s = 0.05;  // no heartbeat for this long: coil to 0 V
  // The fault line is asserted from fault_start_s to fault_end_s (seconds since the start of
  // serving) on the ports that carry one (GPIO line, Modbus sensor block); fault_start_s < 0:
  // never.
  double fault_start_s = -1.0;
  double fault_end_s = -1.0;
};

struct LatencyStats {
  std::uint64_t count = 0;
  double median_us = 0.0, p99_us = 0.0, max_us = 0.0;
};

struct ServeResult {
  std::uint64_t steps = 0;
  std::uint64_t commands = 0;              // set-points received
  std::uint64_t invariant_violations = 0;  // non-finite or outside [0, E_max]
  std::uint64_t heartbeat_timeouts = 0;    // fresh -> stale transitions
  std::uint64_t enabled_steps = 0;         // steps with the coil driven (enabled, heartbeat ok)
  std::uint64_t late_steps = 0;            // periods whose wake-up came after the next deadline
  double rms_force_n = 0.0;                // plant force RMS [N]
  double rms_tracking_error_n = 0.0;       // RMS of force - demand over enabled steps [N]
  double normalised_tracking_error = 0.0;  // ||f - d|| / ||d|| over enabled steps
  double last_applied_v = 0.0;
  std::uint64_t fault_steps = 0;           // steps that published the fault line asserted
  std::uint64_t fault_driven_steps = 0;    // steps driven after one that published it asserted
  std::uint64_t fault_reaction_steps = 0;  // from the first assertion to the coil off (0: never)
  std::uint64_t driven_after_fault_steps = 0;  // steps with the coil driven after the window
  std::uint64_t enable_falls = 0;              // enable high -> low transitions heard
  LatencyStats latency;                        // sensor publish -> command computed from it
  std::vector<std::pair<std::string, PortCounters>> ports;
};

// Runs until duration_s or stop. Ports must be open. Not allocation-free (the latency record
// grows), but bounded per step.
ServeResult Serve(const ServeOptions& options, const std::vector<PlantPort*>& ports,
                  const std::atomic<bool>& stop);

// Median, 99th percentile and maximum of samples [us].
LatencyStats Summarise(std::vector<double> samples_us);

}  // namespace mrd::hil
