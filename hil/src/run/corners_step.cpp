// One 1 ms period of a four-corner run (corners_run.hpp): each corner's sensors and the one
// grant out, every corner's command and status of the tick in, each simulated drive, the full
// car stepped, the period scored.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "corners_run.hpp"
#include "run_internal.hpp"

namespace mrd::hil {

int CornersRun::Step(std::int64_t k) {
  if (can_log_ != nullptr) can_log_->t_ns = k * kPeriodNs;
  if (const int sig = Interrupted()) return EndRun(InterruptText(sig), sig);
  const FullCarSample& now = plant_->Sample();
  for (int i = 0; i < 4; ++i) {
    const FullCarCorner& c = now.corner[static_cast<std::size_t>(i)];
    SensorOutput& o = outs_[static_cast<std::size_t>(i)];
    o = SensorOutput{};
    o.sample.t_s = now.t_s;
    o.sample.x = c.damper_x_cm;
    o.sample.v = c.damper_v_cm_s;
    o.sample.body_velocity = 100.0 * c.body_velocity_m_s;
    o.sample.force = plant_->damper_force_n()[static_cast<std::size_t>(i)];
    o.seq = static_cast<std::uint32_t>(k + 1);
    for (const CornerFaultResult& fr : c_.faults) {
      if (k < fr.onset_step || k >= fr.clear_step || !HitsCorner(fr.fault, i)) continue;
      const SensorFault sf = SensorFaultOf(fr.fault.kind);
      if (sf != SensorFault::kNone && o.fault == SensorFault::kNone) o.fault = sf;
      if (fr.fault.kind == FaultKind::kDriveHeartbeatLoss) o.drive_heartbeat_loss = true;
      if (fr.fault.kind == FaultKind::kDriverFault) o.driver_fault = true;
    }
  }
  if (k == 0 && !modbus_) {  // Modbus: the tables hold the step until the firmware reads it
    if (const int rc = AwaitNodes(); rc != 0) return rc;
  }
  if (awaiting_start_) offered_joined_ = ports_.front()->Joined();
  PublishTick(port_ptrs_, outs_, (k + 1) * kPeriodNs);
  ++c_.grants;
  if (const int rc = Hear(k); rc != 0) return rc;

  CornerValues volts{};
  for (int i = 0; i < 4; ++i) volts[static_cast<std::size_t>(i)] = DriveVolts(k, i);
  FollowFaults(k);
  const FullCarSample& after = plant_->Step(volts);
  scorer_->Add(after);
  ++r_->steps;
  c_.ride.volts_front += volts[kFrontLeft] + volts[kFrontRight];
  c_.ride.volts_rear += volts[kRearLeft] + volts[kRearRight];
  CornerStep row;
  row.t = after.t_s;
  row.heave_accel = after.heave_accel;
  row.pitch_rate = after.pitch_rate;
  row.roll_rate = after.roll_rate;
  for (std::size_t i = 0; i < 4; ++i) {
    const Corner& c = corners_[i];
    Hash(c.set_point);
    Hash(volts[i]);
    row.command[i] = c.set_point;
    row.applied[i] = volts[i];
    row.safe[i] = c.safe;
    row.causes[i] = c.causes;
  }
  if (o_.keep_trace) c_.trace.push_back(row);
  return 0;
}

// Before the first offer: the firmware's bus nodes, one per channel, all on the bus (the
// drives answer its NMT and SDO meanwhile), so the first tick reaches every channel once and
// no offer is repeated (a repeated one would show in the firmware's frame counters, whose
// number would depend on when its nodes joined). Wall clock, within the start-up timeout.
int CornersRun::AwaitNodes() {
  const auto nodes = static_cast<std::int64_t>(ports_.size());
  const std::int64_t until =
      common::MonotonicNs() + static_cast<std::int64_t>(o_.startup_timeout_s * 1e9);
  while (ports_.front()->Joined() < nodes) {
    for (std::size_t i = 0; i < ports_.size(); ++i) ports_[i]->Poll(&corners_[i].in);
    if (const int sig = Interrupted()) return EndRun(InterruptText(sig), sig);
    if (!fw_.Alive()) {
      return EndRun(
          "the firmware exited during start-up (exit " + std::to_string(fw_.status()) + ")", 0);
    }
    if (common::MonotonicNs() >= until) {
      return EndRun("the firmware did not open a bus node per channel (" + std::to_string(nodes) +
                        ") within the start-up timeout (" + FormatSeconds(o_.startup_timeout_s) +
                        "); it was stopped",
                    0);
    }
    Pump(2'000'000);
  }
  return 0;
}

// The tick's command and status of every corner, however long they take (simulated time
// never depends on wall time); a firmware that exits is seen at once, one silent for the
// start-up or command timeout (wall clock) ends the run.
int CornersRun::Hear(std::int64_t k) {
  std::array<DriverInput, 4> fresh;
  for (std::size_t i = 0; i < 4; ++i) {
    fresh[i] = corners_[i].in;
    fresh[i].has_command = fresh[i].has_echo = fresh[i].has_status = fresh[i].has_safe = false;
  }
  const bool alive = fw_.Alive();
  const double wait_s = awaiting_start_ ? o_.startup_timeout_s : o_.command_timeout_s;
  const std::int64_t until = common::MonotonicNs() + static_cast<std::int64_t>(wait_s * 1e9);
  std::int64_t next_check = common::MonotonicNs() + 2'000'000;
  bool check_alive = false;
  while (alive) {
    std::size_t missing = 4;  // the first corner still missing its command or status
    // Every port polled on every round: the drives answer their NMT and SDO requests here.
    for (std::size_t i = 0; i < 4; ++i) {
      ports_[i]->Poll(&fresh[i]);
      if (missing == 4 && !(fresh[i].has_command && fresh[i].has_status)) missing = i;
    }
    if (missing == 4) break;
    if (check_alive && !fw_.Alive()) {
      if (awaiting_start_) {
        return EndRun(
            "the firmware exited during start-up (exit " + std::to_string(fw_.status()) + ")", 0);
      }
      break;  // exited mid-step: the missing commands count as timeouts
    }
    const std::int64_t t = common::MonotonicNs();
    if (const int sig = Interrupted()) return EndRun(InterruptText(sig), sig);
    if (t >= until) {
      return EndRun(
          std::string(awaiting_start_ ? "no firmware answered for every corner within the "
                                        "start-up timeout ("
                                      : "the firmware stopped answering: not every corner's "
                                        "command within the command timeout (") +
              FormatSeconds(wait_s) + ") at step " + std::to_string(k) + "; it was stopped",
          0);
    }
    // The firmware joined the bus after the offer: offer the tick again, once per join.
    const std::int64_t joined = ports_.front()->Joined();
    if (awaiting_start_ && joined > offered_joined_) {
      offered_joined_ = joined;
      PublishTick(port_ptrs_, outs_, (k + 1) * kPeriodNs);
      ++reoffers_;  // not counted in c_.grants (their number depends on wall time)
    }
    const bool moved = Pump(std::min<std::int64_t>(until - t, 2'000'000), missing);
    check_alive = !moved || t >= next_check;
    if (check_alive) next_check = t + 2'000'000;
  }
  if (!alive) Pump(0);
  bool any = false;
  for (int i = 0; i < 4; ++i) {
    Take(k, i, fresh[static_cast<std::size_t>(i)]);
    any = any || fresh[static_cast<std::size_t>(i)].has_command;
  }
  if (any) awaiting_start_ = false;
  return 0;
}

// A corner's command, enable, status and the firmware's heartbeat as its drive heard them.
void CornersRun::Take(std::int64_t k, int i, const DriverInput& fresh) {
  Corner& c = corners_[static_cast<std::size_t>(i)];
  c.heard = fresh.has_command;
  if (fresh.has_command) {
    ++c.fig.commands;
    c.set_point = fresh.volts;
    c.command_sum += std::isfinite(fresh.volts) ? fresh.volts : 0.0;
    if (!std::isfinite(fresh.volts) || fresh.volts < 0.0 || fresh.volts > s_.e_max) {
      ++c.fig.invariant_violations;
    }
    if (fresh.has_safe) {
      c.safe = fresh.safe;
    } else if (fresh.has_enable) {
      c.safe = !fresh.enable;
    }
    if (c.safe) ++c.fig.safe_commands;
  } else {
    ++c.fig.command_timeouts;
  }
  if (fresh.has_enable) {
    c.carries_enable = true;
    c.enable = fresh.enable;
  }
  if (fresh.has_status) c.causes = fresh.status_causes;
  if (fresh.heartbeats > c.hb_count) {
    c.hb_count = fresh.heartbeats;
    c.hb_step = k;
  }
  c.in = fresh;
}

// The corner's simulated drive: its set-point while enabled and the firmware's heartbeat is
// fresh (plant time), else the coil's safe 0 V. [V]
double CornersRun::DriveVolts(std::int64_t k, int i) {
  Corner& c = corners_[static_cast<std::size_t>(i)];
  const bool hb_fresh = k - c.hb_step <= hb_timeout_steps_;
  if (c.hb_fresh_prev && !hb_fresh) ++c.fig.heartbeat_timeouts;
  c.hb_fresh_prev = hb_fresh;
  c.driven = (!c.carries_enable || c.enable) && hb_fresh;
  if (c.driven) ++c.fig.driven_steps;
  return c.driven && std::isfinite(c.set_point) ? std::clamp(c.set_point, 0.0, s_.e_max) : 0.0;
}

// Each fault's figures at period k: the first cause named by a hit corner, each corner's
// first safe command, its safe and commanding periods while the fault lasts, its recovery.
void CornersRun::FollowFaults(std::int64_t k) {
  for (CornerFaultResult& fr : c_.faults) {
    if (k < fr.onset_step) continue;
    const bool during = k < fr.clear_step;
    for (int i = 0; i < 4; ++i) {
      const Corner& c = corners_[static_cast<std::size_t>(i)];
      CornerFaultResult::PerCorner& pc = fr.corners[static_cast<std::size_t>(i)];
      if (!fr.detection && HitsCorner(fr.fault, i) && c.causes != 0) {
        fr.detection = k - fr.onset_step;
      }
      if (!c.heard) continue;
      if (!pc.safe && c.safe) pc.safe = k - fr.onset_step;
      if (during && c.safe) ++pc.safe_steps;
      if (during && !c.safe && c.driven) ++pc.commanding_steps;
      if (!during && !pc.recovery && !c.safe && c.driven) pc.recovery = k - fr.clear_step;
    }
  }
}

// FNV-1a 64 over the value's bytes.
void CornersRun::Hash(double v) {
  unsigned char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  for (const unsigned char x : b) {
    hash_ ^= x;
    hash_ *= 1099511628211ULL;
  }
}

}  // namespace mrd::hil
