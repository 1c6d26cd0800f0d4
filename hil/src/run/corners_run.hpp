#pragma once
// `mrd-hil run` on a full car with [channels]: one firmware drives the four corners' dampers
// over one CAN bus or one Modbus link in lockstep (RunScenario dispatches here; ScenarioRun
// keeps the one-damper runs). CAN (can_profiles): the harness owns the local bus (its relay
// inline, as ScenarioRun's) and plays on it, per corner, the corner's CANopen drive and sensor
// node in the messages of the corner's profile (MakeCanPortsOnRelay: one port per corner, the
// relay's tap fanned out to them). Modbus (modbus_profiles, --transport modbus-tcp or
// modbus-rtu): the harness serves the four maps on one server, one sensor module and one
// driver with a block per corner (MakeModbusProfilePorts: one port per corner); the firmware
// is the link's one master.
// Per 1 ms period k:
//   faults   the schedule's faults active at k, on their corner (or every corner)
//   out      each corner's sensors from the full car (damper motion, body velocity over the
//            corner, the damper force), then ONE grant of (k+1)·T (PublishTick: CAN, one
//            TimeGrant in one relay batch; Modbus, the grant register written with every
//            corner's staged block under one lock)
//   in       waits, however long it takes, until every corner's command and status of the
//            tick came; liveness as ScenarioRun (exit seen at once, silence ends the run)
//   plant    each corner's simulated drive applies its set-point while enabled and the
//            firmware's heartbeat is fresh; the full car steps with the four voltages
// Scores: the full car's ride after the settle time (full_car_ride.hpp), per-corner counters,
// per-fault and per-corner detection, safe state, recovery against the fault policy, and a
// hash of every period's commands (determinism). Start-up: corners_run.cpp; the period:
// corners_step.cpp.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mrd/canbus/local_bus.hpp"
#include "mrd/hil/plants/full_car_plant.hpp"
#include "mrd/hil/run/child.hpp"
#include "mrd/hil/run/run.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "run_session.hpp"

namespace mrd::hil {

// 0, 2 (bad input) or 1 (could not run), as RunScenario.
int RunCorners(const Scenario& scenario, const RunOptions& options, RunResult* r,
               std::string* error);

// The fault hits this corner (0 .. 3): its own, or every corner's (corner -1).
inline bool HitsCorner(const Fault& f, int corner) { return f.corner < 0 || f.corner == corner; }

class CornersRun {
 public:
  CornersRun(const Scenario& scenario, const RunOptions& options, RunResult* r, std::string* error);
  CornersRun(const CornersRun&) = delete;
  CornersRun& operator=(const CornersRun&) = delete;

  int Validate();  // options and profiles
  int BringUp();   // plant, bus, ports, configuration, firmware
  int Step(std::int64_t k);
  std::int64_t steps() const { return steps_; }
  int Teardown();

 private:
  // The simulated drive of one corner and what the harness counts of it.
  struct Corner {
    DriverInput in;
    double set_point = 0.0;
    bool safe = true, enable = false, carries_enable = false, driven = false;
    bool heard = false;  // a command this period
    std::uint16_t causes = 0;
    std::uint64_t hb_count = 0;
    std::int64_t hb_step = 0;
    bool hb_fresh_prev = false;
    double command_sum = 0.0;
    CornerFigures fig;
  };
  int OpenCan();
  int OpenModbus();
  int AwaitNodes();
  int Hear(std::int64_t k);  // re-offers outs_ while the start-up waits
  void Take(std::int64_t k, int i, const DriverInput& fresh);
  double DriveVolts(std::int64_t k, int i);
  void FollowFaults(std::int64_t k);
  bool Pump(std::int64_t timeout_ns, std::size_t corner = 0);
  bool Spawn();
  int Interrupted() const;
  int EndRun(const std::string& why, int sig);
  void StopFirmware();
  void Hash(double v);

  RunOptions o_;
  Scenario s_;
  RunResult* r_;
  std::string* error_;
  bool modbus_ = false;  // over Modbus (modbus_profiles), else CAN
  std::vector<std::shared_ptr<const profile::CanProfile>> profiles_;
  std::vector<std::shared_ptr<const profile::ModbusProfile>> maps_;
  std::unique_ptr<FullCarPlant> plant_;
  std::unique_ptr<FullCarScorer> scorer_;
  std::unique_ptr<CanLog> can_log_;  // --can-log
  // The period's sensor outputs, one per corner (sized once: no allocation per period).
  std::vector<SensorOutput> outs_ = std::vector<SensorOutput>(4);
  std::string endpoint_;
  canbus::LocalBusRelay relay_;
  std::vector<std::unique_ptr<PlantPort>> ports_;
  std::vector<PlantPort*> port_ptrs_;
  std::array<Corner, 4> corners_{};
  Child fw_;
  std::int64_t steps_ = 0;
  std::int64_t hb_timeout_steps_ = 0;
  bool awaiting_start_ = true;
  std::int64_t offered_joined_ = -1;
  std::uint64_t reoffers_ = 0;
  std::uint64_t hash_ = 14695981039346656037ULL;  // FNV-1a 64 offset basis
  std::int64_t wall0_ = 0;
  CornersResult c_;
};

}  // namespace mrd::hil
