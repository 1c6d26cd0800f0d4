// The scenario keys' help text (ScenarioKeysHelp; `mrd-hil --help`).
#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil {
namespace {

constexpr const char* kHelp = R"(Scenario keys (TOML; every key optional unless marked):
  name, description        text
  duration_s               plant time to run [s] (default 5)
  e_max                    highest admissible command [V] (2.25); the invariant's bound
  heartbeat_timeout_ms     simulated driver drops the coil to 0 V without a heartbeat (50)
  [plant]       preset = "paper" | "spencer1997", or params = "FILE.toml" (a Spencer
                parameter file as `mrd generate --params` reads and `mrd fit-spencer` writes,
                relative to the scenario); substeps (RK4 steps per period, 20);
                model = "damper" (default: the damper alone on [excitation]) | "quarter-car"
                (the damper between body and wheel of a quarter car on an ISO 8608 road; the
                road is the excitation; ride figures scored next to passive-off and -on) |
                "narx" (an identified model plays the damper on [excitation]'s motion):
                  file (required: an `mrd identify` model file, relative to the scenario),
                  iteration (default: the file's selected one), envelope_margin (0.1: the
                  model's v, x, E and fed-back force held to its identification range
                  widened by this fraction; every hold counted in the summary) |
                "structure" (the three-story frame of Dyke et al. 1996 with the damper
                between ground and first floor, under [structure]'s ground motion; floor
                displacements, drifts, accelerations and the damper force scored next to
                passive-off and -on; docs/structure.md) |
                "full-car" (the 7-DOF car, the damper at each corner, on two [road] tracks;
                run by `mrd-hil study`, and by `mrd-hil run` with [channels]; docs/study.md)
  [plant.spencer] c0a c0b k0 c1a c1b k1 x0 alpha_a alpha_b gamma beta A n eta: overrides
                of single damper parameters on top of preset or params (damper and quarter car)
  [quarter_car] sprung_mass_kg (300), unsprung_mass_kg (40), spring_n_per_m (20000),
                tyre_n_per_m (180000), motion_ratio (0.7, damper / wheel travel),
                speed_m_s (20), substeps (10), settle_s (2: ride figures scored after it),
                passive_step_v (0.05: the best-passive grid's step over 0 .. E_max [V], each
                constant voltage run on the same road in process; 0: no grid)
  [road]        class = "A" .. "H" ("C"), seed (1), n_min (0.011), n_max (2.83) [cycles/m],
                components (256)
  [full_car]    body_mass_kg (1200), pitch_inertia_kg_m2 (1800), roll_inertia_kg_m2 (450),
                cg_to_front_m (1.2), cg_to_rear_m (1.4), track_front_m (1.5), track_rear_m
                (1.5), unsprung_front_kg (40), unsprung_rear_kg (40), spring_front_n_per_m
                (20000), spring_rear_n_per_m (20000), tyre_n_per_m (180000), motion_ratio
                (0.7), seat_x_m (0.3), seat_y_m (0.37), substeps (10), speed_m_s (20),
                coherence (0.5: left / right track correlation in [0, 1]; the rear wheels
                on the front's tracks a wheelbase later), settle_s (2), passive_step_v (0.05:
                all four at one voltage), pair_step_v (0.25: front / rear grid, <= 100 steps)
  [channels]    full car in `mrd-hil run`: one firmware drives the four corners over one CAN
                bus or one Modbus link in lockstep; can_profiles (4 CAN device profiles,
                front-left, front-right, rear-left, rear-right, relative to the scenario) or
                modbus_profiles (4 Modbus maps, the same order: over Modbus TCP, or
                --transport modbus-rtu), one of them required, fault_policy
                ("all" | "channel"), body_law ("none" | "modal-skyhook": [control] law =
                "force"; else law skyhook, passive-off, passive-on or constant per corner),
                heave_n_s_per_m, pitch_n_m_s_per_rad, roll_n_m_s_per_rad (modal gains;
                default: the firmware's)
  [structure]   record (required: a `t_s,ag_g` CSV of ground acceleration [g], e.g.
                ../data/el_centro_1940_ns.csv, relative to the scenario), time_scale (5: played
                this many times faster), amplitude (1: factor on the record); after the
                record the ground is still (duration_s may run past it)
  [excitation]  kind = "periodic" | "csv" | "profile" | "replay"
                periodic: amplitude_cm, frequency_hz, demand_amplitude_n, demand_frequency_hz,
                          body_amplitude, body_frequency_hz, body_phase_rad
                csv: file (header naming x and v; relative to the scenario file),
                     demand_column (default "f": an `mrd generate` data set's force, reachable
                     by construction)
                profile: profile = "identification" | "v1" | "v2" | "v3" | "wide", seed (1):
                     generated by the harness with the code of `mrd generate --profile P
                     --seed N` (the demand is its force f on the [plant] preset)
                replay: file (a measured run with columns x, v, E, f: `mrd import` or `mrd
                     generate`); the plant follows the measured x, v; law "force" tracks f,
                     law "open-loop" commands the measured E; the summary scores the plant's
                     force against the measured f (fit %, RMSE)
  [control]     law = "force" | "passive-off" | "passive-on" | "constant" | "skyhook" |
                "open-loop" (replay only: the firmware passes the measured E through) |
                "groundhook" | "groundhook-on-off" | "hybrid" | "add" | "sh-add" (quarter car
                only: body acceleration and wheel velocity on the bus; docs/control_laws.md) |
                "clipped-optimal" (structure only: floor accelerations and force on the bus);
                constant_voltage [V]; skyhook_gain, groundhook_gain, hybrid_gain [N s/cm];
                hybrid_alpha [0, 1]; sh_add_alpha [rad/s]; clipped-optimal: gains (required:
                the file `mrd-structure design --out` writes, relative to the scenario),
                clipped_command = "clipped" (default) | "inverse"
  [firmware]    max_age_ms (5), recover_periods (5), velocity_limit [cm/s] (250),
                grant_timeout_ms (10000: lockstep, the firmware stops when no grant came
                for this long): written into the generated mrd-firmware config;
                table = "FILE.bin" (the firmware's table, `mrd export`, relative to the
                scenario; --table overrides; default: the compiled-in table)
  [pass]        max_invariant_violations (0), max_error_reachable, max_error_all,
                min_reachable_share (0.25: with max_error_reachable, the least share of the
                controlled steps whose demand is reachable; below it the run fails, since
                the reachable error would score a small part of it),
                max_missed_grants, max_detection_to_safe_periods (2), require_recovery (true),
                min_replay_fit (replay: least fit % of plant force vs measured f),
                expect_firmware_exit (e.g. 2 with a corrupt_table fault),
                body_accel_below_passive (quarter car: the controlled run's body acceleration
                RMS below both passive-off and passive-on; false),
                tyre_load_below_passive_off (quarter car: the controlled run's tyre load RMS
                below passive-off's, the road-holding score of groundhook and hybrid; false),
                peak_drift_below_passive_on, peak_accel_below_passive_on (structure: the
                largest peak inter-story drift / absolute floor acceleration not above
                passive-on's; false), max_peak_force_n (structure: the peak damper force [N])
  [gpio]        inputs = list of displacement | fault_line; outputs = list of enable |
                heartbeat (routed over GPIO lines instead of CAN; displacement from a
                quadrature encoder the plant drives, velocity differentiated by the firmware);
                counts_per_cm (400), velocity_cutoff_hz (50)
  [[fault]]     kind (required) = drop | delay | corrupt | stall | out_of_range | nan |
                implausible | kill_plant | kill_firmware | corrupt_table | fault_line (a
                [gpio] line or a profile's fault_line input) |
                drive_heartbeat_loss (CANopen profiles: the drive's heartbeat stops) |
                driver_fault (the driver reports a fault: driver_faults, the Modbus
                driver-fault bit) | enable_refused (Modbus profiles: the driver answers
                writes of its enable with exception 0x04);
                at_s (onset), duration_s (0: to the end), delay_periods (delay, 10),
                corner ([channels]: 0 front-left .. 3 rear-right; default every corner;
                drop, corrupt, stall, out_of_range, nan, drive_heartbeat_loss, driver_fault)
)";

}  // namespace

const char* ScenarioKeysHelp() { return kHelp; }

}  // namespace mrd::hil
