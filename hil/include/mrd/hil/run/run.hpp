#pragma once
// `mrd-hil run`: one scenario against a real mrd-firmware process. The harness generates the
// firmware's configuration for the transport, starts the firmware as a child (or attaches to
// one started by hand), plays the plant and the current driver over the transport, applies the
// fault schedule, scores the run and stops the firmware cleanly.
//
// Clocks:
//   lockstep             per step k: sensor frames (registers) of the plant at k·T, then a
//                        TimeGrant frame (the Modbus grant register) of (k+1)·T; the harness
//                        waits for the firmware's command and status of that tick, however
//                        long they take, applies them and steps the plant. Deterministic (no
//                        wall time enters the result) and as fast as both processes allow.
//                        Liveness is separate: a firmware child that exits is seen at once; one
//                        silent for command_timeout (startup_timeout for its first tick) ends
//                        the run with an error. A dead plant (kill_plant) is silent on the bus
//                        while the harness keeps granting time.
//   realtime             the plant steps at 1 kHz on CLOCK_MONOTONIC (absolute deadlines); the
//                        firmware runs on its own clock; wake-up jitter and sensor->command
//                        latency are measured.
// Scores: force tracking ||f - d|| / ||d|| (force and demand at the same plant time) over the
// steps the coil is driven by a non-safe command, over all of them and over the reachable ones
// (d within the forces the damper would give on that step from its present state at 0 V and
// at E_max: Plant::Probe), next to the same figures for two shadow plants on the same
// excitation held at 0 V (passive-off) and E_max (passive-on); the invariant (every received
// command finite and within [0, E_max]); per fault, periods to detection (first step whose firmware
// status names a cause, or the driver's heartbeat loss), to the safe state (first safe command, or
// coil dropped by the driver) and to recovery after the fault clears (first non-safe, driven
// command).

#include <array>
#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mrd/hil/plants/full_car_ride.hpp"
#include "mrd/hil/plants/model_plant.hpp"
#include "mrd/hil/plants/replay.hpp"
#include "mrd/hil/plants/ride.hpp"
#include "mrd/hil/plants/structure_scores.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/hil/run/serve.hpp"
#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil {

struct RunOptions {
  std::string transport = "can";  // can | modbus-tcp | modbus-rtu
  std::string clock;              // lockstep | realtime; "": lockstep
  std::string table;              // table file for the firmware; "": its compiled-in table
  std::string excitation;         // CSV replacing the scenario's excitation ("": keep it)
  std::string firmware;           // mrd-firmware to start
  std::string profile;            // device profile file: CAN ("": the built-in mrd-native) or
                                  // Modbus (a [modbus] section; --transport modbus-tcp|rtu)
  std::string sdo_refuse;         // CANopen profiles, a test hook: "INDEX[:SUB]=ABORT" (hex
                                  // or decimal): the drive refuses that SDO download
  bool attach = false;            // do not start it: wait for one started by hand
  std::string work_dir;           // config, sockets, firmware output (created if absent)
  // Every frame on the harness's local CAN bus, both directions, in candump -L format
  // ("(SECONDS) mrdbus ID#DATA"; SECONDS: the run's time, simulated in lockstep). "": none.
  std::string can_log;
  // The firmware's per-period log (docs/logging.md) in work_dir under this name (the
  // generated config's [log] path); "": none. Lockstep: its t_ns is the run's time.
  std::string firmware_log;
  double command_timeout_s = 10.0;  // lockstep liveness: silence this long ends the run [s]
  double startup_timeout_s = 10.0;  // first sign of life of the firmware [s]
  // Set (to the signal number) by the caller's SIGTERM/SIGINT/SIGHUP handler: the run stops,
  // forwards the signal to the firmware child, reaps it and returns 1 (error "interrupted").
  const std::atomic<int>* interrupt = nullptr;
  bool keep_trace = true;  // record per-step signals and score (false: benchmark;
                           // no probes, no passive twins, no tracking scores)
  // Real devices instead of the build machine's stand-ins (e.g. on the virtual board):
  std::string can_interface;  // SocketCAN interface (CAN_RAW, e.g. "vcan0"); "": the
                              // local frame bus the harness owns
  std::string gpio_sim;       // configfs directory of a live gpio-sim device (its bank0
                              // is the firmware's chip); "": a simulated chip file in
                              // work_dir ([gpio] scenarios only)
};

struct TrackingScores {
  std::uint64_t steps = 0;  // controlled steps scored
  std::uint64_t reachable_steps = 0;
  double reachable_share = 0.0;                   // reachable_steps / steps (0 without a step)
  double error_all = 0.0, error_reachable = 0.0;  // controlled run
  double off_all = 0.0, off_reachable = 0.0;      // passive-off (0 V)
  double on_all = 0.0, on_reachable = 0.0;        // passive-on (E_max)
  double rms_force_n = 0.0, rms_demand_n = 0.0;
  // false: no demand to normalise by (no step, or a zero demand); the errors above read 0.
  bool all_scored = false, reachable_scored = false;
};

// Quarter car: RMS ride figures over the steps after the scenario's settle time.
struct RideFigures {
  std::uint64_t samples = 0;
  double body_accel_rms = 0.0;   // [m/s^2]
  double travel_rms_cm = 0.0;    // suspension travel [cm]
  double tyre_load_rms_n = 0.0;  // tyre load variation [N]
  double max_travel_cm = 0.0;
  std::uint64_t lift_off = 0;  // samples with the wheel off the ground
};
struct RideScores {
  RideFigures controlled, passive_off, passive_on;  // the run; twins at 0 V and at E_max
};

struct FaultResult {
  Fault fault;
  std::int64_t onset_step = 0, clear_step = 0;            // clear_step: steps when it never clears
  std::optional<std::int64_t> detection, safe, recovery;  // periods after onset / after clearing
  bool detection_required = true;
  bool ok = true;
  std::string why;  // when !ok
};

struct StepRecord {
  double t, x, v, demand, force, force_off, force_on, command, applied;
  bool safe, driven, reachable;
  std::uint16_t causes;
  double body_accel = 0.0, body_accel_off = 0.0, body_accel_on = 0.0;  // quarter car [m/s^2]
  // Real time: how old the sample a command heard this step was computed from was when the
  // command left the firmware (its bus stamp minus the harness's publication of the echoed
  // sample) [ms]; -1 without a command or its sample; 0 in lockstep (the step's own sample).
  double command_age_ms = -1.0;
};

// A full car's four corners closed over CAN (a scenario with [channels]; corners_run.hpp).
struct CornerFigures {
  std::string name;     // front-left, front-right, rear-left, rear-right
  std::string profile;  // its CAN device profile
  std::uint64_t commands = 0, safe_commands = 0, driven_steps = 0;
  std::uint64_t invariant_violations = 0, command_timeouts = 0, heartbeat_timeouts = 0;
  double mean_command_v = 0.0;  // over the commands heard [V]
  PortCounters port;
};
// One fault of the schedule as each corner lived it (periods counted from its onset; recovery
// from its clearing).
struct CornerFaultResult {
  Fault fault;
  std::int64_t onset_step = 0, clear_step = 0;
  std::optional<std::int64_t> detection;  // the first status of a hit corner naming a cause
  struct PerCorner {
    std::optional<std::int64_t> safe;      // the first safe command
    std::optional<std::int64_t> recovery;  // the first driven, non-safe command after clearing
    std::uint64_t safe_steps = 0;          // safe commands from onset to clearing
    std::uint64_t commanding_steps = 0;    // driven, non-safe commands from onset to clearing
  };
  std::array<PerCorner, 4> corners;
  bool ok = true;
  std::string why;
};
struct CornerStep {  // one period of corners.csv
  double t = 0.0, heave_accel = 0.0, pitch_rate = 0.0, roll_rate = 0.0;
  std::array<double, 4> command{}, applied{};
  std::array<bool, 4> safe{};
  std::array<std::uint16_t, 4> causes{};
};
struct CornersResult {
  std::string fault_policy, body_law;
  FullCarRidePoint ride;  // after the settle time; volts_*: the mean applied voltages
  double settle_s = 0.0;
  std::string commands_fnv1a;  // FNV-1a 64 of every period's four commands and applied volts
  std::array<CornerFigures, 4> corners;
  std::vector<CornerFaultResult> faults;
  std::uint64_t grants = 0;  // TimeGrant frames of the periods (start-up repeats apart)
  std::vector<CornerStep> trace;
};

struct RunResult {
  std::string clock;  // lockstep | realtime
  std::string transport;
  std::uint64_t steps = 0;
  std::uint64_t commands = 0;
  std::uint64_t invariant_violations = 0;
  std::uint64_t command_timeouts = 0;  // lockstep: ticks whose command did not come in time
  std::uint64_t heartbeat_timeouts = 0;
  std::uint64_t driven_steps = 0;
  std::uint64_t safe_commands = 0;
  std::uint64_t late_steps = 0;  // realtime: wake-ups after the next deadline
  TrackingScores tracking;
  std::optional<RideScores> ride;            // quarter-car scenarios (needs keep_trace)
  std::optional<StructureScores> structure;  // structure scenarios (needs keep_trace)
  std::optional<PassiveBaseline> passive;    // quarter car: the best passive baseline (filled by
                                             // ComputePassiveBaseline, not by RunScenario)
  std::optional<ReplayScores> replay;        // replay scenarios: plant force vs measured f
  std::optional<PlantHolds> plant_holds;     // [plant] model = "narx": envelope holds
  std::optional<CornersResult> corners;      // a full car with [channels]: its four corners
  std::vector<FaultResult> faults;
  int firmware_exit = -1;     // -1: still running / not started by us
  int interrupted = 0;        // the signal that stopped the run (RunOptions::interrupt)
  std::string firmware_json;  // the firmware's --json summary (last instance)
  std::string firmware_stderr;
  std::optional<std::uint64_t> missed_grants;  // from the firmware's summary (lockstep)
  int firmware_starts = 0;
  double wall_s = 0.0;
  double speed_x = 0.0;      // plant time / wall time
  LatencyStats latency;      // sensor publish -> command computed from it
  LatencyStats wake_jitter;  // realtime: wake-up minus deadline
  std::vector<std::pair<std::string, PortCounters>> ports;
  std::vector<StepRecord> trace;
  std::string config_path;
  bool pass = false;
  std::vector<std::string> failures;
};

// 0: ran (result->pass says whether the criteria hold); 2: bad input (*error); 1: could not
// run (*error: ports, firmware start-up).
int RunScenario(const Scenario& scenario, const RunOptions& options, RunResult* result,
                std::string* error);

// The firmware's grant timeout on a transport [ms]: the scenario's, at least 100 ms on Modbus
// (a grant there crosses two more threads, the harness's server and the firmware's worker, so
// a loaded machine must not turn scheduling delays into missed grants).

// The generated mrd-firmware configuration for a transport and endpoint (CAN: a local bus
// socket path, or a SocketCAN interface name when it has no '/'). gpio_chip: where the
// firmware finds the scenario's [gpio] lines (unused without them): a simulated chip's path
// (contains '/') or a GPIO character device for libgpiod (e.g. "gpiochip0"); the line offsets
// are GpioPortConfig's defaults (gpio_port.hpp).
// can_profile: the CAN device profile (its file written as [can] profile; the inputs and
// outputs routed to CAN are those it maps); nullptr: the built-in mrd-native one.
// modbus_profile: the same for Modbus ([modbus] profile; nullptr: the built-in map).
// pwm_sysfs: non-empty for a profile with a [pwm] section: the command leaves CAN for a
// [pwm] section on that sysfs-ABI tree (chip 0, channel 0; the profile is [can]'s).
// A full car with [channels]: one firmware, four channels, one CAN section on the local bus
// at endpoint, each channel's profile from s.channels, lockstep.
std::string CornersConfigText(const Scenario& s, const std::string& endpoint,
                              const profile::CanProfile& first);
// The same over one Modbus link (s.channels.modbus_profiles): transport modbus-tcp (endpoint
// HOST:PORT) or modbus-rtu (endpoint: the pty); one [modbus] section, no profile of its own,
// the inputs the first map holds.
std::string CornersModbusConfigText(const Scenario& s, const std::string& transport,
                                    const std::string& endpoint,
                                    const profile::ModbusProfile& first);

std::string FirmwareConfigText(const Scenario& s, const std::string& transport, bool lockstep,
                               const std::string& endpoint, const std::string& gpio_chip = "",
                               const profile::CanProfile* can_profile = nullptr,
                               const profile::ModbusProfile* modbus_profile = nullptr,
                               const std::string& pwm_sysfs = "");

}  // namespace mrd::hil
