#pragma once
// A HIL scenario (TOML, hil/scenarios/*.toml): plant and excitation, the firmware's control
// law, duration, fault schedule and pass criteria. Keys and meanings: ScenarioKeysHelp() (also
// `mrd-hil --help`). Start-up only (allocates; toml++ exceptions are caught inside).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mrd/sim/damper_plant.hpp"
#include "mrd/sim/full_car.hpp"
#include "mrd/sim/iso8608_road.hpp"
#include "mrd/sim/quarter_car.hpp"

namespace mrd::hil {

enum class FaultKind : std::uint8_t {
  kDrop,          // sensor frames not sent
  kDelay,         // sensor frames held back by delay_periods (sent late, in a burst)
  kCorrupt,       // sensor frames with a flipped data bit (checksum mismatch)
  kStall,         // the sensor repeats its last frames unchanged (repeated rolling counter)
  kOutOfRange,    // velocity raw value beyond the DBC range (decoder refuses it)
  kNan,           // velocity the transport cannot represent (CAN: the NaN-like raw 0x8000)
  kImplausible,   // finite in-range velocity beyond the firmware's velocity_limit
  kKillPlant,     // the plant side's bus node closes, reopens when the fault clears
  kKillFirmware,  // SIGKILL to mrd-firmware; restarted when the fault clears (duration > 0)
  kCorruptTable,  // the firmware is offered a table with a flipped byte: it must refuse (exit 2)
  kFaultLine,     // the driver's fault line asserted (GPIO; needs [gpio] inputs fault_line)
  kDriveHeartbeatLoss,  // a CANopen drive stops its heartbeat (needs a [canopen] profile)
  kDriverFault,         // the simulated driver reports a fault on its status (driver_faults)
  kEnableRefused,       // Modbus profile: the driver answers writes of its enable with an
                        // exception (0x04), the other writes as usual
};
const char* FaultKindName(FaultKind kind);

struct Fault {
  FaultKind kind = FaultKind::kDrop;
  double at_s = 0.0;        // onset (plant time)
  double duration_s = 0.0;  // 0: until the end (kill_firmware: no restart)
  int delay_periods = 10;   // kDelay
  int corner = -1;          // [channels] runs: the corner it hits (0 front-left .. 3 rear-right;
                            // -1: every corner)
  int line = 0;             // in the scenario file
};

// [gpio]: signals routed over GPIO lines next to CAN (docs: ScenarioKeysHelp). Displacement
// comes from a quadrature encoder the plant side drives; the firmware then differentiates it
// for velocity (CAN no longer carries the motion frame's signals to it).
struct ScenarioGpio {
  bool displacement = false;  // encoder A/B lines
  bool fault_line = false;    // driver fault input
  bool enable = false;        // driver enable output
  bool heartbeat = false;     // heartbeat output (toggles per period)
  double counts_per_cm = 400.0;
  double velocity_cutoff_hz = 50.0;  // firmware's displacement differentiator [Hz]
  bool any() const { return displacement || fault_line || enable || heartbeat; }
};

// kProfile: a reference profile of `mrd generate` (mrd/sim/reference_profiles.hpp), generated
// by the harness: motion x, v and the demand (the preset damper's force on it).
enum class ExcitationKind : std::uint8_t { kPeriodic, kCsv, kProfile, kReplay };

// [channels] of a full car: one damper channel per corner of one firmware over one CAN bus or
// one Modbus link (`mrd-hil run` then closes the four corners in lockstep: corners_run.hpp).
struct ScenarioChannels {
  // One CAN device profile per corner (front-left, front-right, rear-left, rear-right),
  // absolute, or one Modbus register map per corner (the same order; the run then goes over
  // Modbus TCP unless --transport modbus-rtu); both empty: no [channels] (the full car runs in
  // `mrd-hil study` only). One of the two at most.
  std::vector<std::string> can_profiles;
  std::vector<std::string> modbus_profiles;
  std::string fault_policy = "all";  // all | channel (the firmware's [channels] fault_policy)
  std::string body_law = "none";     // none | modal-skyhook (the firmware's [channels] body_law)
  // modal-skyhook gains; unset: the firmware's defaults.
  std::optional<double> heave_n_s_per_m, pitch_n_m_s_per_rad, roll_n_m_s_per_rad;
  bool any() const { return !can_profiles.empty() || !modbus_profiles.empty(); }
  bool modbus() const { return !modbus_profiles.empty(); }
};

struct PlantModel;      // model_plant.hpp: an identified NARX model playing the damper
struct StructureSetup;  // structure_plant.hpp: the three-story frame and its ground motion

struct Scenario {
  std::string path, name, description;
  double duration_s = 5.0;
  double e_max = 2.25;                // [V]
  double heartbeat_timeout_s = 0.05;  // simulated driver: coil to 0 V without a heartbeat
  // [plant]
  std::string preset = "paper";
  std::string params_file;       // [plant] params (resolved against the scenario's folder)
  SpencerParams damper;          // the plant's damper: preset or params file, then the
                                 // [plant.spencer] overrides (plant_params.cpp)
  bool plant_overrides = false;  // [plant.spencer] has keys
  int substeps = 20;
  bool quarter_car = false;  // model = "quarter-car": the damper in a quarter car on
                             // an ISO 8608 road ([quarter_car], [road]); else the
                             // damper alone on [excitation]
  QuarterCarParams car;
  RoadParams road;
  // model = "full-car": the 7-DOF car (full_car.hpp) with the damper at each corner on two
  // ISO 8608 tracks ([full_car], [road]); run by `mrd-hil study`, and by `mrd-hil run` with
  // [channels] (four corners of one firmware over CAN). Speed, settle time and
  // passive step share the quarter car's fields (car.speed_m_s, ride_settle_s, passive_step_v).
  bool full_car = false;
  FullCarParams full;
  ScenarioChannels channels;
  double road_coherence = 0.5;   // left / right track correlation rho in [0, 1]
  double pair_step_v = 0.25;     // front / rear passive grid step [V]
  double ride_settle_s = 2.0;    // quarter car: ride figures scored after this [s]
  double passive_step_v = 0.05;  // quarter car: passive grid step over [0, e_max] [V];
                                 // 0: no passive grid (passive_baseline.hpp)
  // model = "narx": an identified model (file, iteration) plays the damper on the excitation's
  // motion; loaded and checked by LoadScenario (model_plant.hpp). nullptr: the Spencer damper.
  std::shared_ptr<const PlantModel> plant_model;
  // model = "structure": the three-story frame under a ground-acceleration record
  // ([structure]: record, time_scale, amplitude; loaded and checked by LoadScenario).
  bool structure = false;
  std::shared_ptr<const StructureSetup> structure_setup;
  // [excitation]
  ExcitationKind excitation = ExcitationKind::kPeriodic;
  PlantExcitation periodic;
  std::string csv_file;  // resolved against the scenario's folder
  std::string demand_column = "f";
  std::string profile;  // kProfile: v1, v2, ... (ReferenceProfileNames)
  std::uint64_t profile_seed = 1;
  // [control]
  std::string law = "force";  // force | passive-off | passive-on | constant | skyhook |
                              // open-loop (replay: the measured E, replay.hpp)
  double constant_voltage = 0.0;
  double skyhook_gain = 50.0;
  double groundhook_gain = 50.0;            // [N s/cm]
  double hybrid_gain = 50.0;                // [N s/cm]
  double hybrid_alpha = 0.5;                // [0, 1]
  double sh_add_alpha = 9.42;               // [rad/s]
  std::string clipped_gains;                // law "clipped-optimal": the gains file (resolved)
  std::string clipped_command = "clipped";  // clipped | inverse
  // [firmware] settings of the generated configuration
  double max_age_ms = 5.0;
  int recover_periods = 5;
  double velocity_limit = 250.0;
  double grant_timeout_ms = 10000.0;  // lockstep: the firmware stops without grants this long
  std::string table_file;             // [firmware] table: the firmware's table (relative to
                                      // the scenario; --table overrides); "": compiled-in
  // [pass]
  std::uint64_t max_invariant_violations = 0;
  std::optional<double> max_error_reachable;  // ||f - d|| / ||d|| over reachable demands
  // With max_error_reachable: the least share of the controlled steps that must be reachable
  // for that error to score the run (below it the run fails, saying so).
  double min_reachable_share = 0.25;
  std::optional<double> max_error_all;
  std::optional<double> min_replay_fit;  // replay: plant force vs measured f [%]
  std::optional<std::uint64_t> max_missed_grants;
  int max_detection_to_safe_periods = 2;
  bool require_recovery = true;
  std::optional<int> expect_firmware_exit;   // e.g. 2 for a refused table
  bool body_accel_below_passive = false;     // quarter car: controlled < passive-off and -on
  bool tyre_load_below_passive_off = false;  // quarter car: tyre load RMS < passive-off's
  // Structure: the controlled run's largest peak drift / peak absolute floor acceleration
  // (over the floors) not above passive-on's; the peak damper force at most this [N].
  bool peak_drift_below_passive_on = false;
  bool peak_accel_below_passive_on = false;
  std::optional<double> max_peak_force_n;
  std::vector<Fault> faults;
  ScenarioGpio gpio;
};

// false: *error = "FILE:LINE: reason".
bool LoadScenario(const std::string& path, Scenario* scenario, std::string* error);
// The same with overrides applied to the file's TOML before it is read (scenario_set.hpp):
// each "KEY=VALUE", KEY a dotted path (control.skyhook_gain), VALUE typed as TOML (a word that
// is no TOML value is a string). The same checks apply; an error caused by an override names
// it ("--set KEY=VALUE: reason").
bool LoadScenario(const std::string& path, const std::vector<std::string>& sets, Scenario* scenario,
                  std::string* error);
// Every key with its meaning (for --help).
const char* ScenarioKeysHelp();
// The laws that read body acceleration or wheel velocity (groundhook, groundhook-on-off,
// hybrid, add, sh-add): quarter car only.
bool IsChassisLaw(const std::string& law);

}  // namespace mrd::hil
