#pragma once
// mrd-firmware configuration (TOML, read once at start-up). Example with every key and its
// default (all optional):
//
//   [loop]
//   period_us = 1000          # control period [us]
//   priority = 80             # SCHED_FIFO priority (1-99); 0 = do not ask for real time
//   lock_memory = true        # mlockall(MCL_CURRENT | MCL_FUTURE)
//
//   [control]
//   law = "force"             # force | constant | skyhook-on-off | skyhook
//   e_max = 2.25              # highest command [V]; default: the table's E_max
//   constant_voltage = 0.0    # [V], law = "constant" (passive-off 0, passive-on E_max)
//   skyhook_gain = 100.0      # [N s/cm], law = "skyhook"
//   force_limit = 5000.0      # |force demand| limit [N]
//
//   [velocity]
//   source = "measured"       # measured | displacement (filtered differentiator)
//   cutoff_hz = 50.0          # differentiator cut-off [Hz]
//
//   [safety]
//   safe_voltage = 0.0        # safe-state command [V]
//   max_age_ms = 5.0          # sensor data older than this is stale [ms]
//   recover_periods = 1       # clean periods before leaving the safe state
//   velocity_limit = 0.0      # |v| above this is implausible: safe state [cm/s]; 0 = none
//   displacement_limit = 0.0  # |x| above this is implausible: safe state [cm]; 0 = none
//
//   [simulation]              # the dry-run plant (SimulationConfig)
//   amplitude_cm = 1.0, frequency_hz = 2.0, demand_amplitude_n = 600.0,
//   demand_frequency_hz = 0.5, body_amplitude = 8.0, body_frequency_hz = 1.3, substeps = 20
//
//   [can] / [modbus] / [gpio]  # bus sections (io_config.hpp): inputs, outputs, connection

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io_config.hpp"
#include "mrd/firmware/simulated_damper.hpp"

namespace mrd::firmware {

struct FirmwareConfig {
  std::int64_t period_ns = 1'000'000;
  int priority = 80;
  bool lock_memory = true;
  std::optional<double> e_max;  // [V]; unset: the table's
  ControllerConfig controller;
  SimulationConfig simulation;
  IoConfig io;  // [can], [modbus], [gpio]; none: dry run on the simulated damper
};

// Parses TOML text (source names it in messages). Unknown keys, wrong types and out-of-range
// values are errors: returns false with *error = "SOURCE:LINE: reason". Start-up only
// (allocates; toml++ exceptions are caught inside).
bool ParseConfig(std::string_view text, const std::string& source, FirmwareConfig* config,
                 std::string* error);
// Reads and parses a file; false with *error on a missing file or bad content.
bool LoadConfigFile(const std::string& path, FirmwareConfig* config, std::string* error);

}  // namespace mrd::firmware
