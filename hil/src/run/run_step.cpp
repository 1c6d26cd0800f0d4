// The scenario run's third phase (run_session.hpp): one 1 ms period. The fault schedule, the
// plant's sensors out (and, lockstep, the tick's grant), the firmware's command and lines in,
// the simulated current driver, the plant and its passive twins stepped.
#include <algorithm>
#include <cmath>

#include "run_internal.hpp"
#include "run_session.hpp"

namespace mrd::hil {

int ScenarioRun::Step(std::int64_t k) {
  can_log_.t_ns = lockstep_ ? k * kPeriodNs : -1;  // -1: stamp with CLOCK_MONOTONIC
  if (const int sig = Interrupted()) return EndRun(InterruptText(sig), sig);
  StepFaults faults;
  if (const int rc = ApplyFaultSchedule(k, &faults); rc != 0) return rc;
  FollowPlantNode(faults);
  const SensorOutput out = PublishSensors(k, faults);
  if (!lockstep_) Pump(0);  // on its way to the firmware (lockstep: HearLockstep relays)

  // Hear the firmware.
  DriverInput fresh = in_;
  fresh.has_command = fresh.has_echo = fresh.has_status = fresh.has_safe = false;
  if (lockstep_) {
    if (const int rc = HearLockstep(k, out, faults.plant_dead, &fresh); rc != 0) return rc;
  } else if (port_open_) {
    Pump(0);
    port_->Poll(&fresh);
    pwm_.Poll(&fresh);
  }
  gpio_.Poll(&fresh);  // written in the same firmware tick as the command heard above
  const double command_age_ms = TakeCommand(fresh);
  TakeLines(k, fresh);
  in_ = fresh;
  StepPlants(DriverVolts(k), command_age_ms);
  deadline_ += kPeriodNs;
  return 0;
}

// The fault schedule at step k: what is active, and kill_firmware's kill and restart.
int ScenarioRun::ApplyFaultSchedule(std::int64_t k, StepFaults* sf) {
  for (const Fault& f : s_.faults) {
    const auto k0 = static_cast<std::int64_t>(std::llround(f.at_s / 1e-3));
    const auto k1 = f.duration_s > 0.0
                        ? k0 + static_cast<std::int64_t>(std::llround(f.duration_s / 1e-3))
                        : steps_;
    const bool active = k >= k0 && k < k1;
    if (f.kind == FaultKind::kKillFirmware) {
      if (k == k0 && !o_.attach) fw_.Kill();
      if (k == k1 && f.duration_s > 0.0 && !fw_.Alive()) {
        // Restart: the previous instance's summary is kept under its own name.
        if (!Spawn(error_)) return 1;
        awaiting_start_ = true;
      }
    }
    if (!active) continue;
    if (SensorFaultOf(f.kind) != SensorFault::kNone && sf->sensor == SensorFault::kNone) {
      sf->sensor = SensorFaultOf(f.kind);
    }
    if (f.kind == FaultKind::kDelay) {
      sf->delay = true;
      sf->delay_periods = f.delay_periods;
    }
    if (f.kind == FaultKind::kImplausible) sf->implausible = true;
    if (f.kind == FaultKind::kKillPlant) sf->plant_dead = true;
    if (f.kind == FaultKind::kFaultLine) sf->fault_line = true;
    if (f.kind == FaultKind::kDriveHeartbeatLoss) sf->drive_heartbeat_loss = true;
    if (f.kind == FaultKind::kDriverFault) sf->driver_fault = true;
    if (f.kind == FaultKind::kEnableRefused) sf->enable_refused = true;
  }
  return 0;
}

// Real time: the plant's bus node goes away. Lockstep: the harness is also the clock, so
// time goes on (grants) while the plant's node is silent (no sensor data).
void ScenarioRun::FollowPlantNode(const StepFaults& f) {
  if (f.plant_dead && port_open_ && !lockstep_) {
    port_->Close();
    port_open_ = false;
  } else if (!f.plant_dead && !port_open_) {
    std::string e;
    port_open_ = port_->Open(&e);
  }
}

// Publish this step's sensors (and grant its tick). Real time: at the step's deadline.
SensorOutput ScenarioRun::PublishSensors(std::int64_t k, const StepFaults& f) {
  const Scenario& s = s_;
  SensorOutput out;
  out.sample = sample_;
  if (f.implausible) {
    out.sample.v = std::min(299.0, std::max(s.velocity_limit * 1.2, s.velocity_limit + 10.0));
  }
  out.seq = static_cast<std::uint32_t>(k + 1) + (lockstep_ ? 0 : seq_base_);
  out.fault = f.sensor;
  out.fault_line = f.fault_line;
  out.drive_heartbeat_loss = f.drive_heartbeat_loss;
  out.driver_fault = f.driver_fault;
  out.enable_refused = f.enable_refused;
  if (!lockstep_) {
    (void)common::SleepUntilNs(deadline_);
    const std::int64_t now = common::MonotonicNs();
    jitter_us_.push_back(static_cast<double>(now - deadline_) * 1e-3);
    if (now - deadline_ > kPeriodNs) ++r_->late_steps;
  }
  gpio_.Publish(out, lockstep_);  // lockstep: settled before the grant below
  if (lockstep_ && awaiting_start_) offered_joined_ = port_->Joined();  // who gets this offer
  if (port_open_) {
    if (f.plant_dead) {
      // lockstep: silent plant, granted time (above)
    } else if (f.delay || !delayed_.empty()) {
      delayed_.push_back(out);
      while (!delayed_.empty() &&
             (!f.delay ||
              static_cast<std::int64_t>(out.seq - delayed_.front().seq) >= f.delay_periods)) {
        Publish(delayed_.front());
        delayed_.pop_front();
      }
    } else {
      Publish(out);
    }
    if (lockstep_) port_->SendGrant((k + 1) * kPeriodNs);
  }
  return out;
}

// Lockstep: the tick's command and status (the generated config sends a status every period),
// however long they take: simulated time never depends on wall time. Liveness is separate: a
// firmware that exits is seen at once; one that stays silent for the start-up or command
// timeout (wall clock) ends the run with an error.
int ScenarioRun::HearLockstep(std::int64_t k, const SensorOutput& out, bool plant_dead,
                              DriverInput* fresh) {
  const RunOptions& o = o_;
  if (!FirmwareAlive()) {
    Pump(0);  // the bus still relayed (a restarted firmware joins)
    return 0;
  }
  const double wait_s = awaiting_start_ ? o.startup_timeout_s : o.command_timeout_s;
  const std::int64_t until = common::MonotonicNs() + static_cast<std::int64_t>(wait_s * 1e9);
  std::int64_t resend = common::MonotonicNs() + 50'000'000;
  // Whether to ask if the firmware still runs (a waitpid): not just after the check above, nor
  // after a wait that relayed frames (it was alive then; an exit closes its socket, and the
  // wait after that relays nothing), but at least every 2 ms (another node's frames).
  bool check_alive = false;
  std::int64_t next_check = common::MonotonicNs() + 2'000'000;
  while (true) {
    port_->Poll(fresh);
    // PWM: the tick's status frame says its duty is written (run_pwm.hpp).
    if (pwm_.active() && fresh->has_status) pwm_.Poll(fresh);
    if (fresh->has_command && (fresh->has_status || !port_->CarriesStatus())) break;
    if (check_alive && !FirmwareAlive()) {
      // Exited before its first command: it refused to start (its stderr says why).
      if (awaiting_start_ && !o.attach) {
        return EndRun(
            "the firmware exited during start-up (exit " + std::to_string(fw_.status()) + ")", 0);
      }
      break;  // exited mid-step: no command for this step
    }
    const std::int64_t now = common::MonotonicNs();
    if (const int sig = Interrupted()) return EndRun(InterruptText(sig), sig);
    if (now >= until) {
      return EndRun(
          std::string(awaiting_start_ ? "no firmware answered within the start-up timeout ("
                                      : "the firmware stopped answering: no command within "
                                        "the command timeout (") +
              FormatSeconds(wait_s) + ") at step " + std::to_string(k) +
              (o.attach ? "" : "; it was stopped"),
          0);
    }
    // The firmware may not have been on the bus for the offer: offer the step again. Where the
    // port counts the peers that joined (the harness's own CAN relay), only when one joined
    // since the last offer: the firmware then gets the step exactly once, however long its
    // start-up takes (its frame and grant counters stay deterministic); else every 50 ms.
    const std::int64_t joined = port_->Joined();
    if (awaiting_start_ && (joined < 0 ? now >= resend : joined > offered_joined_)) {
      offered_joined_ = joined;
      if (!plant_dead) {
        Publish(out);
        ++reoffers_;
      }
      port_->SendGrant((k + 1) * kPeriodNs);
      resend = now + 50'000'000;
    }
    const bool moved = Pump(std::min<std::int64_t>(until - now, 2'000'000));
    check_alive = !moved || now >= next_check;
    if (check_alive) next_check = now + 2'000'000;
  }
  if (!fresh->has_command)
    ++r_->command_timeouts;
  else
    awaiting_start_ = false;
  return 0;
}

// A command heard: the set-point, the invariant, the safe flag, the latency of its echoed
// sample. Returns the command's age [ms] (-1: none; StepRecord::command_age_ms).
double ScenarioRun::TakeCommand(const DriverInput& fresh) {
  double command_age_ms = -1.0;
  if (!fresh.has_command) return command_age_ms;
  ++r_->commands;
  set_point_ = fresh.volts;
  if (!std::isfinite(fresh.volts) || fresh.volts < 0.0 || fresh.volts > s_.e_max + e_tolerance_) {
    ++r_->invariant_violations;
  }
  // The safe flag where the transport carries it (CAN); else the enable (Modbus).
  if (fresh.has_safe) {
    cmd_safe_ = fresh.safe;
  } else if (fresh.has_enable) {
    cmd_safe_ = !fresh.enable;
  }
  if (cmd_safe_) ++r_->safe_commands;
  if (fresh.has_echo) {
    const std::size_t slot = fresh.echo % kRing;
    if (published_seq_[slot] == fresh.echo && published_ns_[slot] != 0) {
      latency_us_.push_back(static_cast<double>(fresh.command_ns - published_ns_[slot]) * 1e-3);
      command_age_ms = lockstep_ ? 0.0 : latency_us_.back() * 1e-3;
    }
  }
  return command_age_ms;
}

// The enable, the status causes and the heartbeat as the firmware drives them.
void ScenarioRun::TakeLines(std::int64_t k, const DriverInput& fresh) {
  if (fresh.has_enable) {
    carries_enable_ = true;
    enable_ = fresh.enable;
  }
  if (fresh.has_status) causes_ = fresh.status_causes;
  if (fresh.has_watchdog) watchdog_ok_ = fresh.watchdog_ok;
  if (fresh.heartbeats > hb_count_) {
    hb_count_ = fresh.heartbeats;
    hb_step_ = k;
  }
  if (fresh.heartbeat_ns != 0) hb_ns_ = fresh.heartbeat_ns;
}

// The simulated current driver: the set-point while enabled and the heartbeat is fresh (in
// plant time under lockstep, wall time in real time; only where the profile has a heartbeat)
// and its communication watchdog (if any) has not tripped; else the coil's safe 0 V. [V]
double ScenarioRun::DriverVolts(std::int64_t k) {
  const Scenario& s = s_;
  // A driver without heartbeat supervision (its profile maps none) applies every command.
  const bool hb_fresh =
      !supervise_hb_ ||
      (lockstep_ ? k - hb_step_ <= hb_timeout_steps_
                 : hb_ns_ != 0 && common::MonotonicNs() - hb_ns_ <=
                                      static_cast<std::int64_t>(s.heartbeat_timeout_s * 1e9));
  if (hb_fresh_prev_ && !hb_fresh) ++r_->heartbeat_timeouts;
  hb_fresh_prev_ = hb_fresh;
  driven_ = (!carries_enable_ || enable_) && hb_fresh && watchdog_ok_;
  const double applied =
      driven_ && std::isfinite(set_point_) ? std::clamp(set_point_, 0.0, s.e_max) : 0.0;
  if (driven_) ++r_->driven_steps;
  return applied;
}

// Step the plant and its passive twins; the figures and the trace record.
void ScenarioRun::StepPlants(double applied, double command_age_ms) {
  const RunOptions& o = o_;
  const Scenario& s = s_;
  const double v_seen = sample_.v;
  // What the damper can deliver on this step from its present state (0 V .. E_max).
  // (Scoring only: without a trace, e.g. the benchmark, neither the probes nor the passive
  // twins run.)
  double reach_a = 0.0, reach_b = 0.0, f_off = 0.0, f_on = 0.0;
  if (o.keep_trace) {
    reach_a = plant_->Probe(0.0).force;
    reach_b = plant_->Probe(s.e_max).force;
    f_off = plant_off_->Step(0.0).force;
    f_on = plant_on_->Step(s.e_max).force;
  }
  sample_ = plant_->Step(applied);
  ++r_->steps;
  if (score_ride_ && sample_.t_s > s.ride_settle_s) {
    ride_.Add(*plant_->Ride());
    ride_off_.Add(*plant_off_->Ride());
    ride_on_.Add(*plant_on_->Ride());
  }
  if (score_floors_) {
    floors_.Add(*plant_->Structure());
    floors_off_.Add(*plant_off_->Structure());
    floors_on_.Add(*plant_on_->Structure());
  }
  if (o.keep_trace) {
    const double lo = std::min(reach_a, reach_b), hi = std::max(reach_a, reach_b);
    r_->trace.push_back({sample_.t_s, sample_.x, v_seen, sample_.demand, sample_.force, f_off, f_on,
                         set_point_, applied, cmd_safe_, driven_,
                         sample_.demand >= lo && sample_.demand <= hi, causes_});
    r_->trace.back().command_age_ms = command_age_ms;
    if (score_ride_) {
      r_->trace.back().body_accel = plant_->Ride()->body_accel;
      r_->trace.back().body_accel_off = plant_off_->Ride()->body_accel;
      r_->trace.back().body_accel_on = plant_on_->Ride()->body_accel;
    }
  }
}

}  // namespace mrd::hil
