// The scenario run's second phase (run_session.hpp): the plant and its passive twins, the
// transport's port, the [gpio] and [pwm] sides, the firmware's configuration and its start.
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "mrd/hil/plants/excitation_profile.hpp"
#include "mrd/hil/plants/model_plant.hpp"
#include "mrd/hil/plants/structure_plant.hpp"
#include "run_internal.hpp"
#include "run_session.hpp"

namespace mrd::hil {
namespace {

std::unique_ptr<Plant> MakePlant(const Scenario& s, const SpencerParams& p, const Trace* trace) {
  if (s.plant_model != nullptr) {  // the model on the Spencer plant's motion (model_plant.hpp)
    Scenario motion = s;
    motion.plant_model = nullptr;
    return std::make_unique<ModelPlant>(s.plant_model, MakePlant(motion, p, trace));
  }
  if (s.quarter_car) return std::make_unique<QuarterCarAdapter>(p, s.car, s.road, 1e-3);
  if (s.structure) return std::make_unique<StructurePlant>(s.structure_setup, p, 1e-3, s.substeps);
  if (trace != nullptr) return std::make_unique<TracePlant>(p, *trace, 1e-3, s.substeps);
  PlantExcitation e = s.periodic;
  e.substeps = s.substeps;
  return std::make_unique<DamperPlantAdapter>(p, e, 1e-3);
}

}  // namespace

int ScenarioRun::BringUp(bool* finished) {
  *finished = false;
  if (const int rc = MakePlants(); rc != 0) return rc;
  if (!MakeDirs(o_.work_dir)) {
    *error_ = o_.work_dir + ": cannot create (" + std::strerror(errno) + ")";
    return 1;
  }
  if (const int rc = OpenPort(); rc != 0) return rc;
  if (!gpio_.Open(s_, o_, &gpio_chip_, error_)) return 1;
  if (pwm_profile_ && !pwm_.Open(can_profile_->path, o_.work_dir, &pwm_sysfs_, error_)) return 2;
  WriteConfig();
  if (corrupt_table_) {
    *finished = true;
    const std::function<void(std::int64_t)> pump = [this](std::int64_t ns) { Pump(ns); };
    const int rc = RunCorruptTable(s_, o_, *port_, pump, r_->config_path, r_, error_);
    port_->Close();
    r_->ports.emplace_back(port_->name(), port_->counters());
    if (rc == 0) EvaluatePass(s_, r_);
    return rc;
  }
  if (const int rc = StartFirmware(); rc != 0) return rc;
  if (const int rc = AwaitRealtimeStart(); rc != 0) return rc;
  // Real time: 1 ns timer slack instead of the default 50 us (no privilege needed), so the
  // wake-up jitter measured is the scheduler's, not the slack's.
  if (!lockstep_) prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  wall0_ = common::MonotonicNs();
  deadline_ = wall0_;
  return 0;
}

// The excitation (a CSV, a replayed record or a generated profile) and three plants on it:
// the controlled one and its passive twins (0 V, E_max).
int ScenarioRun::MakePlants() {
  const RunOptions& o = o_;
  const Scenario& s = s_;
  const SpencerParams params =
      s.damper;  // preset, params file, overrides (scenario/plant_params.cpp)
  replaying_ = !s.quarter_car && s.excitation == ExcitationKind::kReplay;
  const bool generated =
      !s.quarter_car && o.excitation.empty() && s.excitation == ExcitationKind::kProfile;
  const bool csv = !s.quarter_car && !generated &&
                   (s.excitation == ExcitationKind::kCsv || replaying_ || !o.excitation.empty());
  const std::string csv_path = o.excitation.empty() ? s.csv_file : o.excitation;
  if (replaying_
          ? !LoadReplay(csv_path, s.law == "open-loop", s.demand_column, &trace_, &replay_, error_)
          : csv && !LoadTrace(csv_path, s.demand_column, &trace_, error_)) {
    return 2;
  }
  if (generated && !ProfileTrace(s.profile, s.profile_seed, params, &trace_, error_)) return 2;
  const Trace* tp = csv || generated ? &trace_ : nullptr;
  plant_ = MakePlant(s, params, tp);
  plant_off_ = MakePlant(s, params, tp);
  plant_on_ = MakePlant(s, params, tp);
  return 0;
}

// The transport's endpoint. On CAN the harness owns the local frame bus, runs its relay
// inline (Pump: forwarding happens in the harness's own waits, so a lockstep round costs
// two wake-ups, harness -> firmware -> harness, instead of four through a relay thread) and is
// an in-process node of it (no socket round trip of its own); the plant's node can go away
// and come back (kill_plant).
int ScenarioRun::OpenPort() {
  const RunOptions& o = o_;
  const bool can = transport_ == Transport::kCan;
  relay_bus_ = can && o.can_interface.empty();  // else SocketCAN (CAN_RAW)
  if (can && !relay_bus_) {
    endpoint_ = o.can_interface;
    port_ = MakeCanPort(endpoint_, can_profile_);
  } else if (can) {
    endpoint_ = o.work_dir + "/canbus.sock";
    if (!relay_.Open(endpoint_, error_)) return 1;
    port_ = MakeCanPortOnRelay(relay_, can_profile_);
    if (!o.can_log.empty() && !can_log_.Open(o.can_log, error_)) return 1;
    if (can_log_.file != nullptr) relay_.SetLog(&CanLog::Write, &can_log_);
  } else if (transport_ == Transport::kModbusRtu) {
    endpoint_ = o.work_dir + "/modbus-pty";
    port_ = modbus_profile_ != nullptr ? MakeModbusProfilePort(true, endpoint_, modbus_profile_)
                                       : MakeModbusRtuPort(endpoint_);
  }
  if (transport_ == Transport::kModbusTcp) {
    if (const int rc = OpenModbusTcp(); rc != 0) return rc;
  } else if (port_ == nullptr || !port_->Open(error_)) {
    if (port_ == nullptr) *error_ = o.transport + ": transport not available in this build";
    return 1;
  }
  port_open_ = true;
  port_->SetLockstep(lockstep_);
  if (refusal_.index >= 0) port_->RefuseSdo(refusal_.index, refusal_.subindex, refusal_.code);
  return 0;
}

// A free port near a per-process base.
int ScenarioRun::OpenModbusTcp() {
  const int base = 20000 + static_cast<int>(getpid() % 20000);
  for (int i = 0; i < 50 && port_ == nullptr; ++i) {
    endpoint_ = "127.0.0.1:" + std::to_string(base + i * 7);
    auto p = modbus_profile_ != nullptr ? MakeModbusProfilePort(false, endpoint_, modbus_profile_)
                                        : MakeModbusTcpPort(endpoint_);
    std::string e;
    if (p != nullptr && p->Open(&e)) port_ = std::move(p);
  }
  if (port_ == nullptr) {
    *error_ = "modbus-tcp: no free port to listen on";
    return 1;
  }
  return 0;
}

// WORK_DIR/firmware.toml: the generated configuration, the control socket, the period log.
void ScenarioRun::WriteConfig() {
  const RunOptions& o = o_;
  std::string config =
      FirmwareConfigText(s_, TransportName(transport_), lockstep_, endpoint_, gpio_chip_,
                         can_profile_.get(), modbus_profile_.get(), pwm_sysfs_);
  // The firmware's control socket in the run's folder (mrd-firmware ctl --socket
  // WORK_DIR/ctl.sock; docs/tuning.md), when the path fits a UNIX socket address.
  if (const std::string ctl = o.work_dir + "/ctl.sock";
      ctl.size() <= 107 && std::none_of(ctl.begin(), ctl.end(), [](char ch) {
        return ch == '"' || ch == '\\' || static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f;
      })) {
    config += "\n[ctl]\nsocket = \"" + ctl + "\"\n";
  }
  r_->config_path = o.work_dir + "/firmware.toml";
  std::ofstream(r_->config_path) << config
                                 << (o.firmware_log.empty()
                                         ? std::string()
                                         : "\n[log]\npath = \"" + o.firmware_log + "\"\n");
}

// The firmware started (or awaited, --attach) and the per-step state set up.
int ScenarioRun::StartFirmware() {
  const RunOptions& o = o_;
  const Scenario& s = s_;
  steps_ = static_cast<std::int64_t>(std::llround(s.duration_s / 1e-3));
  // Lockstep: the firmware stops itself at the run's end (its duration counts granted time).
  // One period more than the run: the firmware's shutdown (safe command block, enable low)
  // right after its last tick would race the harness reading that tick's command; the final
  // grant (Teardown) gives it the extra tick.
  fw_duration_ = lockstep_ ? static_cast<double>(steps_ + 1) * 1e-3 : 0.0;
  if (!Spawn(error_)) return 1;
  if (o.attach) {
    std::fprintf(
        stderr, "mrd-hil: waiting for a firmware started by hand:\n  mrd-firmware --config %s%s\n",
        r_->config_path.c_str(), lockstep_ ? " (lockstep: add --duration to stop it)" : "");
  }
  // A PWM duty is rounded to the nearest ns: E_max may come back up to half a step above.
  e_tolerance_ = pwm_.active() ? 0.5 * pwm_.QuantumVolts(s.e_max) + 1e-12 : 0.0;
  hb_step_ = std::numeric_limits<std::int64_t>::min() / 2;
  published_ns_.assign(kRing, 0);
  published_seq_.assign(kRing, 0);
  latency_us_.reserve(static_cast<std::size_t>(steps_) + 16);
  if (!lockstep_) jitter_us_.reserve(static_cast<std::size_t>(steps_) + 16);
  if (o.keep_trace) r_->trace.reserve(static_cast<std::size_t>(steps_));
  hb_timeout_steps_ = static_cast<std::int64_t>(std::llround(s.heartbeat_timeout_s / 1e-3));
  supervise_hb_ = s.gpio.heartbeat || port_->CarriesHeartbeat();
  // Quarter car: ride figures of the run and of its passive twins after the settle time.
  score_ride_ = o.keep_trace && plant_->Ride() != nullptr;
  // Structure: floor figures of the run and of its passive twins over every step.
  score_floors_ = o.keep_trace && plant_->Structure() != nullptr;
  sample_ = plant_->Sample();
  return 0;
}

// Real time: start when the firmware shows a sign of life (a heartbeat or command), with the
// first sample on the bus meanwhile.
int ScenarioRun::AwaitRealtimeStart() {
  if (lockstep_) return 0;
  const std::int64_t until =
      common::MonotonicNs() + static_cast<std::int64_t>(o_.startup_timeout_s * 1e9);
  std::uint32_t seq = 0;
  while (true) {
    SensorOutput out;
    out.sample = sample_;
    out.seq = ++seq;
    Publish(out);
    DriverInput fresh = in_;
    port_->Poll(&fresh);
    pwm_.Poll(&fresh);  // the channel enabled: the firmware is up
    in_ = fresh;
    if (in_.heartbeat_ns != 0 || in_.has_command) break;
    if (const int sig = Interrupted()) return EndRun(InterruptText(sig), sig);
    if (!FirmwareAlive() || common::MonotonicNs() > until) {
      *error_ = FirmwareAlive() ? "the firmware did not answer within the start-up timeout"
                                : "the firmware exited during start-up";
      r_->firmware_exit = o_.attach ? -1 : fw_.Stop(2.0);
      ReadFile(o_.work_dir + "/firmware.err", &r_->firmware_stderr);
      return 1;
    }
    PumpFor(kPeriodNs);
  }
  in_.has_command = false;
  awaiting_start_ = false;
  return 0;
}

}  // namespace mrd::hil
