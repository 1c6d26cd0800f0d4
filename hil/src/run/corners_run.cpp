// A full car's four corners over CAN (corners_run.hpp): validation, bring-up, teardown and
// the judgement of the fault schedule against the fault policy. The period: corners_step.cpp.
#include "corners_run.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>

#include "mrd/common/lockstep_sched.hpp"
#include "run_session.hpp"

namespace mrd::hil {
namespace {

constexpr const char* kCornerNames[4] = {"front-left", "front-right", "rear-left", "rear-right"};

}  // namespace

int RunCorners(const Scenario& scenario, const RunOptions& options, RunResult* r,
               std::string* error) {
  CornersRun run(scenario, options, r, error);
  if (const int rc = run.Validate(); rc != 0) return rc;
  const common::ScopedLockstepScheduling sched(true);
  if (const int rc = run.BringUp(); rc != 0) return rc;
  for (std::int64_t k = 0; k < run.steps(); ++k) {
    if (const int rc = run.Step(k); rc != 0) return rc;
  }
  return run.Teardown();
}

CornersRun::CornersRun(const Scenario& scenario, const RunOptions& options, RunResult* r,
                       std::string* error)
    : o_(options), s_(scenario), r_(r), error_(error) {
  if (o_.table.empty()) o_.table = s_.table_file;
}

// Lockstep on the harness's own CAN bus (can_profiles) or its own Modbus server
// (modbus_profiles); the corners' profiles are the scenario's.
int CornersRun::Validate() {
  const RunOptions& o = o_;
  const auto refuse = [&](const std::string& why) {
    *error_ = s_.path + ": four corners ([channels]) " + why;
    return 2;
  };
  modbus_ = s_.channels.modbus();
  if (!modbus_ && o.transport != "can") {
    return refuse("on can_profiles run over --transport can only (Modbus takes modbus_profiles)");
  }
  if (modbus_ && o.transport != "modbus-tcp" && o.transport != "modbus-rtu") {
    return refuse(
        "on modbus_profiles run over --transport modbus-tcp or modbus-rtu (CAN takes "
        "can_profiles)");
  }
  if (!o.clock.empty() && o.clock != "lockstep") return refuse("run in --clock lockstep only");
  if (!o.profile.empty()) return refuse("take their profiles from [channels], not --profile");
  if (!o.can_interface.empty()) return refuse("run on the harness's local bus, not SocketCAN");
  if (!o.excitation.empty()) return refuse("are excited by their [road], not --excitation");
  if (!o.sdo_refuse.empty() || o.attach || !o.gpio_sim.empty()) {
    return refuse("take no --sdo-refuse, --attach or --gpio-sim");
  }
  if (modbus_ && !o.can_log.empty()) return refuse("over Modbus take no --can-log");
  for (const std::string& path : s_.channels.can_profiles) {
    auto p = std::make_shared<profile::CanProfile>();
    std::string why;
    if (!profile::LoadCanProfile(path, p.get(), &why)) {
      *error_ = "[channels] can_profiles: " + why;
      return 2;
    }
    if (!p->inputs[static_cast<std::size_t>(profile::CanIn::kGrant)].mapped()) {
      *error_ = "[channels] can_profiles: " + path + ": lockstep needs a 'grant' input";
      return 2;
    }
    profiles_.push_back(std::move(p));
  }
  for (const std::string& path : s_.channels.modbus_profiles) {
    auto p = std::make_shared<profile::ModbusProfile>();
    std::string why;
    if (!profile::LoadModbusProfile(path, p.get(), &why)) {
      *error_ = "[channels] modbus_profiles: " + why;
      return 2;
    }
    if (maps_.empty() && !p->In(profile::CanIn::kGrant).mapped) {
      *error_ = "[channels] modbus_profiles: " + path + ": lockstep needs a 'grant' input";
      return 2;
    }
    maps_.push_back(std::move(p));
  }
  r_->clock = "lockstep";
  r_->transport = o.transport;
  return 0;
}

int CornersRun::BringUp() {
  const Scenario& s = s_;
  FullCarPlantParams p;
  p.damper = s.damper;  // the reference damper, or the scenario's fitted [plant]
  p.damper_substeps = s.substeps;
  p.car = s.full;
  p.road.road = s.road;
  p.road.correlation = s.road_coherence;
  p.speed_m_s = s.car.speed_m_s;
  p.max_volts = s.e_max;
  plant_ = std::make_unique<FullCarPlant>(p, 1e-3);
  scorer_ = std::make_unique<FullCarScorer>(s.ride_settle_s, 1e3);
  if (!MakeDirs(o_.work_dir)) {
    *error_ = o_.work_dir + ": cannot create (" + std::strerror(errno) + ")";
    return 1;
  }
  if (const int rc = modbus_ ? OpenModbus() : OpenCan(); rc != 0) return rc;
  for (std::size_t i = 0; i < ports_.size(); ++i) {
    ports_[i]->SetLockstep(true);
    port_ptrs_.push_back(ports_[i].get());
    corners_[i].fig.name = kCornerNames[i];
    corners_[i].fig.profile = modbus_ ? maps_[i]->path : profiles_[i]->path;
    corners_[i].hb_step = std::numeric_limits<std::int64_t>::min() / 2;
  }
  r_->config_path = o_.work_dir + "/firmware.toml";
  std::ofstream(r_->config_path) << (modbus_ ? CornersModbusConfigText(s, o_.transport, endpoint_,
                                                                       *maps_.front())
                                             : CornersConfigText(s, endpoint_, *profiles_.front()))
                                 << (o_.firmware_log.empty()
                                         ? std::string()
                                         : "\n[log]\npath = \"" + o_.firmware_log + "\"\n");
  steps_ = static_cast<std::int64_t>(std::llround(s.duration_s / 1e-3));
  hb_timeout_steps_ = static_cast<std::int64_t>(std::llround(s.heartbeat_timeout_s / 1e-3));
  for (const Fault& f : s.faults) {
    CornerFaultResult fr;
    fr.fault = f;
    fr.onset_step = static_cast<std::int64_t>(std::llround(f.at_s / 1e-3));
    fr.clear_step =
        f.duration_s > 0.0
            ? fr.onset_step + static_cast<std::int64_t>(std::llround(f.duration_s / 1e-3))
            : steps_;
    fr.clear_step = std::min(fr.clear_step, steps_);
    c_.faults.push_back(fr);
  }
  c_.fault_policy = s.channels.fault_policy;
  c_.body_law = s.channels.body_law;
  c_.settle_s = s.ride_settle_s;
  if (o_.keep_trace) c_.trace.reserve(static_cast<std::size_t>(steps_));
  if (!Spawn()) return 1;
  wall0_ = common::MonotonicNs();
  return 0;
}

// The harness's local CAN bus and a port per corner on it.
int CornersRun::OpenCan() {
  endpoint_ = o_.work_dir + "/canbus.sock";
  if (!relay_.Open(endpoint_, error_)) return 1;
  if (!o_.can_log.empty()) {
    can_log_ = std::make_unique<CanLog>();
    if (!can_log_->Open(o_.can_log, error_)) return 1;
    relay_.SetLog(&CanLog::Write, can_log_.get());
  }
  ports_ = MakeCanPortsOnRelay(relay_, profiles_);
  for (auto& p : ports_) {
    if (!p->Open(error_)) return 1;
  }
  return 0;
}

// One Modbus server for the four maps (TCP: on a free port near a per-process base; RTU: a
// pseudo-terminal in the run's folder) and a port per corner on it.
int CornersRun::OpenModbus() {
  const bool rtu = o_.transport == "modbus-rtu";
  const int base = 20000 + static_cast<int>(getpid() % 20000);
  for (int i = 0; i < (rtu ? 1 : 50) && ports_.empty(); ++i) {
    endpoint_ = rtu ? o_.work_dir + "/modbus-pty" : "127.0.0.1:" + std::to_string(base + i * 7);
    auto ports = MakeModbusProfilePorts(rtu, endpoint_, maps_, error_);
    if (ports.empty()) return 2;  // the maps cannot share one link
    bool open = true;
    for (auto& p : ports) open = open && p->Open(error_);
    if (open) ports_ = std::move(ports);
  }
  if (ports_.empty()) {
    if (!rtu) *error_ = "modbus-tcp: no free port to listen on";
    return 1;
  }
  return 0;
}

bool CornersRun::Spawn() {
  // One period more than the run: the final grant (StopFirmware) lets it end by itself.
  const double duration = static_cast<double>(steps_ + 1) * 1e-3;
  if (!fw_.Spawn(FirmwareArgv(o_, r_->config_path, o_.table, duration),
                 o_.work_dir + "/firmware.json", o_.work_dir + "/firmware.err", error_)) {
    return false;
  }
  ++r_->firmware_starts;
  return true;
}

// CAN: the relay forwards for up to timeout_ns (true: it moved frames). Modbus: the server
// answers on its own threads; waits up to timeout_ns for corner's command.
bool CornersRun::Pump(std::int64_t timeout_ns, std::size_t corner) {
  if (modbus_) {
    ports_[corner]->Wait(timeout_ns);
    return true;
  }
  return relay_.Step(static_cast<int>((timeout_ns + 999'999) / 1'000'000));
}

int CornersRun::Interrupted() const {
  return o_.interrupt != nullptr ? o_.interrupt->load(std::memory_order_relaxed) : 0;
}

int CornersRun::EndRun(const std::string& why, int sig) {
  *error_ = why;
  r_->interrupted = sig;
  r_->firmware_exit = fw_.Stop(2.0, sig != 0 ? sig : SIGTERM);
  ReadFile(o_.work_dir + "/firmware.err", &r_->firmware_stderr);
  for (auto& p : ports_) p->Close();
  return 1;
}

void CornersRun::StopFirmware() {
  if (fw_.Alive()) {
    ports_.front()->SendGrant((steps_ + 1) * kPeriodNs);  // its last tick's grant
    const std::int64_t until =
        common::MonotonicNs() + static_cast<std::int64_t>(o_.command_timeout_s * 1e9);
    while (fw_.Alive() && common::MonotonicNs() < until) Pump(2'000'000);
    if (fw_.Alive()) fw_.Stop(2.0);
  }
  r_->firmware_exit = fw_.status();
  ReadFile(o_.work_dir + "/firmware.json", &r_->firmware_json);
  ReadFile(o_.work_dir + "/firmware.err", &r_->firmware_stderr);
  const auto at = r_->firmware_json.find("\"missed_grants\":");
  if (at != std::string::npos) {
    r_->missed_grants = std::strtoull(r_->firmware_json.c_str() + at + 16, nullptr, 10);
  }
}

// Each fault against the policy: the hit corners detect it and go safe within
// max_detection_to_safe_periods of the detection; under "all" every corner does, under
// "channel" the others keep commanding through it; after it clears, recovery (where required).
static void JudgeFault(const Scenario& s, std::int64_t steps, CornerFaultResult* fr) {
  const bool all = s.channels.fault_policy == "all";
  const auto fail = [&](const std::string& why) {
    if (fr->ok) fr->why = why;
    fr->ok = false;
  };
  if (!fr->detection) fail("no hit corner's status named a cause");
  const std::int64_t window = fr->clear_step - fr->onset_step;
  for (int i = 0; i < 4; ++i) {
    const CornerFaultResult::PerCorner& pc = fr->corners[static_cast<std::size_t>(i)];
    const std::string name = kCornerNames[i];
    if (HitsCorner(fr->fault, i) || all) {
      if (!pc.safe) {
        fail(name + " never commanded its safe value");
      } else if (fr->detection && *pc.safe - *fr->detection > s.max_detection_to_safe_periods) {
        fail(name + " safe " + std::to_string(*pc.safe - *fr->detection) +
             " periods after the detection (limit " +
             std::to_string(s.max_detection_to_safe_periods) + ")");
      }
      if (s.require_recovery && fr->fault.duration_s > 0.0 && fr->clear_step < steps &&
          !pc.recovery) {
        fail(name + " did not recover after the fault cleared");
      }
    } else if (pc.safe_steps > 0 || static_cast<std::int64_t>(pc.commanding_steps) != window) {
      fail(name + " (not hit, policy channel) commanded " + std::to_string(pc.commanding_steps) +
           " of " + std::to_string(window) + " periods, " + std::to_string(pc.safe_steps) +
           " safe");
    }
  }
}

int CornersRun::Teardown() {
  r_->wall_s = static_cast<double>(common::MonotonicNs() - wall0_) * 1e-9;
  r_->speed_x = r_->wall_s > 0.0 ? static_cast<double>(r_->steps) * 1e-3 / r_->wall_s : 0.0;
  StopFirmware();
  for (std::size_t i = 0; i < ports_.size(); ++i) {
    ports_[i]->Close();
    PortCounters counters = ports_[i]->counters();
    // Start-up offers repeated for a firmware not on the bus yet are no steps.
    counters.published -= std::min(counters.published, reoffers_);
    Corner& c = corners_[i];
    c.fig.port = counters;
    c.fig.mean_command_v =
        c.fig.commands > 0 ? c.command_sum / static_cast<double>(c.fig.commands) : 0.0;
    c_.corners[i] = c.fig;
    r_->ports.emplace_back((modbus_ ? "modbus-" : "can-") + c.fig.name, counters);
    r_->commands += c.fig.commands;
    r_->safe_commands += c.fig.safe_commands;
    r_->driven_steps += c.fig.driven_steps;
    r_->invariant_violations += c.fig.invariant_violations;
    r_->command_timeouts += c.fig.command_timeouts;
    r_->heartbeat_timeouts += c.fig.heartbeat_timeouts;
  }
  const FullCarRidePoint ride = scorer_->Point();
  c_.ride.body_accel_rms = ride.body_accel_rms;
  c_.ride.body_accel_wk_rms = ride.body_accel_wk_rms;
  c_.ride.pitch_rate_rms = ride.pitch_rate_rms;
  c_.ride.roll_rate_rms = ride.roll_rate_rms;
  c_.ride.tyre_load_rms_n = ride.tyre_load_rms_n;
  c_.ride.samples = ride.samples;
  c_.ride.lift_off = ride.lift_off;
  const double n = 2.0 * static_cast<double>(std::max<std::int64_t>(steps_, 1));
  c_.ride.volts_front /= n;  // sums of the applied volts (Step) into means
  c_.ride.volts_rear /= n;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(hash_));
  c_.commands_fnv1a = hex;
  std::vector<std::string>& f = r_->failures;
  for (CornerFaultResult& fr : c_.faults) {
    JudgeFault(s_, steps_, &fr);
    if (!fr.ok) f.push_back(std::string("fault ") + FaultKindName(fr.fault.kind) + ": " + fr.why);
  }
  if (r_->invariant_violations > s_.max_invariant_violations) {
    f.push_back(std::to_string(r_->invariant_violations) +
                " commands outside [0, e_max] or not finite");
  }
  if (r_->command_timeouts > 0) {
    f.push_back(std::to_string(r_->command_timeouts) + " corner-periods without a command");
  }
  if (s_.max_missed_grants && r_->missed_grants && *r_->missed_grants > *s_.max_missed_grants) {
    f.push_back(std::to_string(*r_->missed_grants) + " missed grants");
  }
  if (r_->firmware_exit != 0) {
    f.push_back("the firmware exited with " + std::to_string(r_->firmware_exit));
  }
  r_->pass = f.empty();
  r_->corners = std::move(c_);
  return 0;
}

}  // namespace mrd::hil
