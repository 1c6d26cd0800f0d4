#pragma once
// The phases of one `mrd-hil run` (run.hpp RunScenario), as a class whose methods are them:
//   Validate  (run_validate.cpp)  options and scenario checked, transport and clock parsed once,
//                                 device profiles loaded; 2 and *error on bad input
//   BringUp   (run_bring_up.cpp)  plants, the transport's port, GPIO and PWM sides, the
//                                 firmware's configuration, its start (or a corrupt_table run)
//   Step      (run_step.cpp)      one 1 ms period: faults, sensors out, commands in, plant
//   Teardown  (run_teardown.cpp)  the firmware stopped, its output read, the run scored
// Waits, publication, the firmware child: run_io.cpp. Helpers (names, clock, files, firmware
// argv): run_support.cpp. RunScenario itself: run.cpp.

#include <cstdint>
#include <cstdio>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mrd/canbus/local_bus.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/hil/plants/plant.hpp"
#include "mrd/hil/run/child.hpp"
#include "mrd/hil/run/run.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "run_gpio.hpp"
#include "run_pwm.hpp"

namespace mrd::hil {

inline constexpr std::int64_t kPeriodNs = 1'000'000;  // the plant's step [ns]

enum class Transport { kCan, kModbusTcp, kModbusRtu };
enum class Clock { kLockstep, kRealtime };
// The names RunOptions and RunResult carry ("can", "modbus-tcp", "modbus-rtu"; "lockstep",
// "realtime"). Parse*: false for any other name.
const char* TransportName(Transport t);
const char* ClockName(Clock c);
bool ParseTransport(const std::string& name, Transport* t);
bool ParseClock(const std::string& name, Clock* c);

std::string FormatSeconds(double s);  // "%.3g s"
std::string Tag(int n);               // output suffix of the n-th firmware instance ("" first)
std::string InterruptText(int sig);   // "interrupted by SIGNAL NAME"
bool MakeDirs(const std::string& dir);
bool ReadFile(const std::string& path, std::string* out);

// --can-log: frames in candump -L format, stamped with the run's time (lockstep: the step's
// simulated time; real time and before the first step: CLOCK_MONOTONIC).
struct CanLog {
  FILE* file = nullptr;
  std::int64_t t_ns = -1;
  bool Open(const std::string& path, std::string* error);
  static void Write(void* context, const void* frame, bool in_process);
  CanLog() = default;
  CanLog(const CanLog&) = delete;
  CanLog& operator=(const CanLog&) = delete;
  ~CanLog();
};

// --sdo-refuse "INDEX[:SUB]=ABORT" (C integer syntax: 0x6060, 24672).
struct SdoRefusal {
  int index = -1, subindex = -1;
  std::uint32_t code = 0;
};
bool ParseSdoRefusal(const std::string& text, SdoRefusal* r);

// The firmware's argv for this run (duration_s <= 0: no --duration).
std::vector<std::string> FirmwareArgv(const RunOptions& o, const std::string& config,
                                      const std::string& table, double duration_s);

// A corrupt_table scenario (run_corrupt_table.cpp): the firmware is offered a table with one
// flipped byte and must refuse it (exit 2) without ever driving the coil.
int RunCorruptTable(const Scenario& s, const RunOptions& o, PlantPort& port,
                    const std::function<void(std::int64_t)>& pump, const std::string& config,
                    RunResult* r, std::string* error);

class ScenarioRun {
 public:
  // options.table "": the scenario's [firmware] table.
  ScenarioRun(const Scenario& scenario, const RunOptions& options, RunResult* r,
              std::string* error);
  ScenarioRun(const ScenarioRun&) = delete;
  ScenarioRun& operator=(const ScenarioRun&) = delete;

  // Each: 0 to go on; else RunScenario's return value (2 bad input, 1 could not run).
  int Validate();
  // Plants, port, lines, configuration; a corrupt_table run is played here to its end
  // (*finished true); else the firmware started (and, real time, heard from).
  int BringUp(bool* finished);
  int Step(std::int64_t k);
  std::int64_t steps() const { return steps_; }
  bool lockstep() const { return lockstep_; }
  // After the last step: the firmware stopped, the ports closed, the run scored.
  int Teardown();

 private:
  // Validate
  int ValidateOptions();
  int LoadProfile();
  int LoadCanProfile();
  int LoadModbusProfile();
  int ValidateProfileNeeds();
  // BringUp
  int MakePlants();
  int OpenPort();
  int OpenModbusTcp();
  void WriteConfig();
  int StartFirmware();
  int AwaitRealtimeStart();
  // Step
  struct StepFaults {
    SensorFault sensor = SensorFault::kNone;
    bool delay = false, implausible = false, plant_dead = false, fault_line = false;
    bool drive_heartbeat_loss = false, driver_fault = false, enable_refused = false;
    int delay_periods = 0;
  };
  int ApplyFaultSchedule(std::int64_t k, StepFaults* f);
  void FollowPlantNode(const StepFaults& f);
  SensorOutput PublishSensors(std::int64_t k, const StepFaults& f);
  int HearLockstep(std::int64_t k, const SensorOutput& out, bool plant_dead, DriverInput* fresh);
  double TakeCommand(const DriverInput& fresh);
  void TakeLines(std::int64_t k, const DriverInput& fresh);
  double DriverVolts(std::int64_t k);
  void StepPlants(double applied, double command_age_ms);
  // Helpers (the former lambdas)
  bool Pump(std::int64_t timeout_ns);  // true: frames moved on the harness's relay
  void PumpFor(std::int64_t ns);
  void Publish(SensorOutput out);
  bool Spawn(std::string* e);
  bool FirmwareAlive() { return o_.attach || fw_.Alive(); }
  int Interrupted() const;
  int EndRun(const std::string& why, int sig);
  void StopFirmware();

  // Inputs
  RunOptions o_;  // with the scenario's table when --table names none
  Scenario s_;    // [gpio] enable and heartbeat forced on for a PWM profile
  RunResult* r_;
  std::string* error_;
  Transport transport_ = Transport::kCan;
  Clock clock_ = Clock::kLockstep;
  bool lockstep_ = true;
  bool pwm_profile_ = false;
  bool corrupt_table_ = false;
  std::shared_ptr<const profile::CanProfile> can_profile_;
  std::shared_ptr<const profile::ModbusProfile> modbus_profile_;
  SdoRefusal refusal_;
  // Plants (declared in the order the former locals were: destroyed in reverse)
  Trace trace_;
  bool replaying_ = false;
  ReplayRun replay_;  // the measured force (replay.hpp)
  std::unique_ptr<Plant> plant_, plant_off_, plant_on_;
  // Transport
  std::string endpoint_;
  canbus::LocalBusRelay relay_;
  CanLog can_log_;  // --can-log: closed when the run ends
  std::unique_ptr<PlantPort> port_;
  bool relay_bus_ = false;
  bool port_open_ = true;
  RunGpio gpio_;  // the scenario's [gpio] lines (none without)
  std::string gpio_chip_;
  RunPwm pwm_;  // the profile's PWM output (none without [pwm])
  std::string pwm_sysfs_;
  // Firmware
  std::int64_t steps_ = 0;
  double fw_duration_ = 0.0;
  Child fw_;
  // Per-step state
  double e_tolerance_ = 0.0;
  DriverInput in_;
  double set_point_ = 0.0;
  bool cmd_safe_ = true, enable_ = false, carries_enable_ = false;
  bool driven_ = false;  // this step's coil driven (DriverVolts)
  std::uint16_t causes_ = 0;
  std::uint64_t hb_count_ = 0;
  std::int64_t hb_step_ = 0;
  std::int64_t hb_ns_ = 0;
  bool hb_fresh_prev_ = false;
  bool watchdog_ok_ = true;  // the driver's communication watchdog (DriverInput)
  bool awaiting_start_ = true;
  std::int64_t offered_joined_ = -1;  // lockstep start-up: port_->Joined() at the last offer
  std::uint64_t reoffers_ = 0;        // start-up offers repeated (not counted as published)
  std::deque<SensorOutput> delayed_;
  std::vector<double> latency_us_, jitter_us_;
  static constexpr std::size_t kRing = 4096;
  std::vector<std::int64_t> published_ns_;
  std::vector<std::uint32_t> published_seq_;
  std::int64_t hb_timeout_steps_ = 0;
  bool supervise_hb_ = true;  // the driver watches a heartbeat (port or [gpio] line)
  RideMetrics ride_, ride_off_, ride_on_;
  bool score_ride_ = false;
  StructureMetrics floors_, floors_off_, floors_on_;
  bool score_floors_ = false;
  PlantSample sample_;
  std::int64_t wall0_ = 0;
  std::int64_t deadline_ = 0;
  std::uint32_t seq_base_ = 1000;  // real time: above the start-up publications
};

}  // namespace mrd::hil
