#pragma once
// mrd-firmware configuration (TOML, read once at start-up). Sections [loop], [control],
// [velocity], [safety], [simulation], [channels] (several channels); every key with its default,
// unit and range is in docs/firmware_config.md, generated from the key table in
// firmware/platform/src/config.cpp (ConfigReference). Example:
//
//   [loop]
//   period_us = 1000
//   [control]
//   law = "force"
//   [can] / [modbus] / [gpio]  # bus sections (io_config.hpp): inputs, outputs, connection

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/io_config.hpp"
#include "mrd/firmware/platform/channels_config.hpp"
#include "mrd/firmware/platform/log_config.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"

namespace mrd::firmware::platform {

// Where the loop's time comes from (bus mode): CLOCK_MONOTONIC, or the HIL harness's time
// grants on the CAN bus (lockstep, grant_clock.hpp).
enum class LoopClock : std::uint8_t { kMonotonic = 0, kGrant };

struct FirmwareConfig {
  std::int64_t period_ns = 1'000'000;
  LoopClock clock = LoopClock::kMonotonic;
  std::int64_t grant_timeout_ns = 10'000'000'000;  // lockstep: no grant this long = stop [ns]
  int priority = 80;
  bool lock_memory = true;
  std::optional<double> e_max;  // [V]; unset: the table's
  ControllerConfig controller;
  SimulationConfig simulation;
  IoConfig io;              // [can], [modbus], [gpio], [pwm]; none: dry run on the simulated damper
  bool ctl_enable = false;  // [ctl]: serve the control socket (params_server.hpp)
  std::string ctl_socket;   // its path; "": DefaultCtlSocket()
  LogConfig log;            // [log]: the per-period log (period_log.hpp)
  // [clipped_optimal] gains: the gains file as given (relative to the config file); loaded
  // into controller.clipped_gains by the parse (clipped_optimal_file.hpp).
  std::string clipped_gains_path;
  ChannelsConfig channels;  // [channels]: several damper channels (channels_config.hpp)
};

// When a change of a key takes effect: at the next start only; on a reload (SIGHUP: a fresh
// controller, model state reset); or while the loop runs (mrd-firmware ctl set, at a period
// boundary, model state kept; also on a reload).
enum class Tunable : std::uint8_t { kRestart = 0, kReload, kRuntime };
const char* TunableName(Tunable t);  // "restart", "reload", "runtime"

// One key of the table as a parameter, "section.key", its current value as TOML.
struct ParamInfo {
  std::string name;
  std::string value;
  std::string type;     // "float", "integer", "bool", "choice", "string", "list"
  std::string unit;     // "" when none
  std::string accepts;  // range or choices in words
  Tunable tunable = Tunable::kRestart;
};

// Every key of the table with its value in config (e_max: the effective one). Not real-time.
std::vector<ParamInfo> ListParams(const FirmwareConfig& config);
// Sets the runtime-tunable key `name` ("section.key") from `value` (a TOML value; a bare word
// is taken as a string) with the setter and range of ParseConfig, then the cross-checks
// against the buses. False with *why (unknown name, wrong type, out of range, not tunable at
// runtime, a bus that does not serve what the value needs); *config unchanged then.
// Not real-time.
bool SetParam(FirmwareConfig* config, std::string_view name, std::string_view value,
              std::string* why);
// Names of the keys that need a restart ("section.key", or "[section]" for a bus section
// added or removed) whose values differ between the running and the next config.
std::vector<std::string> RestartKeysChanged(const FirmwareConfig& running,
                                            const FirmwareConfig& next);
// The control socket's default path: $XDG_RUNTIME_DIR/mrd-firmware.sock, else
// /run/mrd-firmware/ctl.sock.
std::string DefaultCtlSocket();

// Parses TOML text (source names it in messages). Unknown keys, wrong types and out-of-range
// values are errors: returns false with *error = "SOURCE:LINE: reason" (source and reason
// as mrd::Printable). Start-up only
// (allocates; toml++ exceptions are caught inside).
bool ParseConfig(std::string_view text, const std::string& source, FirmwareConfig* config,
                 std::string* error);
// The configuration reference (Markdown) generated from the key table: every section and key
// with its default, unit, accepted values and meaning. "" if it cannot be built (no memory).
std::string ConfigReference();

// Longest config file [bytes].
inline constexpr std::uint64_t kMaxConfigBytes = 1 << 20;

// Reads and parses a file; false with *error on a missing file, a path that is not a regular
// file (directory, FIFO, device: refused without blocking), a file over kMaxConfigBytes, or
// bad content. Messages echo input as mrd::Printable (control bytes as \xNN, at most 400
// characters).
bool LoadConfigFile(const std::string& path, FirmwareConfig* config, std::string* error);

}  // namespace mrd::firmware::platform
