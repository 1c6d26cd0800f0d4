#include "mrd/firmware/channel.hpp"

#include <cmath>

namespace mrd::firmware {

namespace {

void CopyTiming(const LoopTiming& timing, TelemetrySnapshot* stats) {
  stats->overruns = timing.overruns;
  stats->missed_periods = timing.missed_periods;
  stats->worst_latency_ns = timing.worst_latency_ns;
  stats->worst_exec_ns = timing.worst_exec_ns;
  stats->last_exec_ns = timing.last_exec_ns;
}

}  // namespace

Channel::Channel(SensorSource& source, CurrentDriver& driver, Controller& controller,
                 Telemetry& telemetry)
    : source_(source), driver_(driver), controller_(&controller), telemetry_(telemetry) {}

void Channel::Begin(const IoTime& io) {
  // A period boundary: pending parameter changes and reloads apply here.
  if (hook_ != nullptr) {
    Controller* next = hook_->BeforePeriod(*controller_, stats_.ticks, io.loop_ns);
    if (next != nullptr && next != controller_) {
      // A reload: the old controller's counters are carried into the totals.
      base_model_resets_ += controller_->model_resets();
      base_input_excursions_ += controller_->input_excursions();
      base_force_excursions_ += controller_->force_excursions();
      const WatchdogCounters& w = controller_->watchdog().counters();
      for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
        base_watchdog_.active_periods[i] += w.active_periods[i];
        base_watchdog_.trips[i] += w.trips[i];
      }
      base_watchdog_.safe_periods += w.safe_periods;
      base_watchdog_.entries += w.entries;
      controller_ = next;
    }
  }
  frame_ = SensorFrame{};
  read_ = source_.Read(io, &frame_);
  if (read_ == IoStatus::kFault) ++stats_.read_faults;
}

void Channel::Finish(const IoTime& io, double dt_s, bool peer_fault, const LoopTiming& timing,
                     bool defer_record) {
  frame_.peer_fault = peer_fault;
  const ControllerOutput out = controller_->Update(frame_, read_, driver_fault_, io.loop_ns, dt_s);

  // Write; a failed command falls back to the safe state at once.
  const IoStatus write =
      out.safe ? driver_.EnterSafeState(io, out.volts) : driver_.Command(io, out.volts);
  if (write == IoStatus::kFault) {
    ++stats_.write_faults;
    if (!out.safe) (void)driver_.EnterSafeState(io, controller_->config().safe_voltage);
  }
  driver_fault_ = write == IoStatus::kFault;

  Count(out, timing);
  telemetry_.Write(stats_);
  driver_.PublishStatus(io, stats_);
  if (observer_ == nullptr) return;  // the record is the observer's alone
  Record(io, out, write);
  if (!defer_record) observer_->OnPeriod(record_);
}

void Channel::Count(const ControllerOutput& out, const LoopTiming& timing) {
  ++stats_.ticks;
  CopyTiming(timing, &stats_);
  if (out.force_law) {
    if (out.passive) {
      ++stats_.passive_demands;
    } else if (!out.reachable) {
      ++stats_.unreachable;
    }
    if (!out.monotone) ++stats_.non_monotone;
  }
  stats_.model_resets = base_model_resets_ + controller_->model_resets();
  stats_.envelope_excursions = base_input_excursions_ + controller_->input_excursions();
  stats_.force_excursions = base_force_excursions_ + controller_->force_excursions();
  stats_.watchdog = controller_->watchdog().counters();
  for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
    stats_.watchdog.active_periods[i] += base_watchdog_.active_periods[i];
    stats_.watchdog.trips[i] += base_watchdog_.trips[i];
  }
  stats_.watchdog.safe_periods += base_watchdog_.safe_periods;
  stats_.watchdog.entries += base_watchdog_.entries;
  stats_.active_causes = out.causes;
  stats_.safe = out.safe;
  stats_.last_command_v = out.volts;
  stats_.model_force_n = out.model_force;
  stats_.force_demand_n = out.force_demand;
  stats_.measured_force_n = frame_[Input::kForce].value;
  if (!out.safe && std::isfinite(frame_[Input::kForce].value)) {
    const double e = out.model_force - frame_[Input::kForce].value;
    stats_.sum_sq_model_error += e * e;
    ++stats_.force_samples;
    if (out.force_law) {
      const double t = out.force_demand - frame_[Input::kForce].value;
      stats_.sum_sq_tracking_error += t * t;
      ++stats_.tracking_samples;
    }
  }
}

// The period's record (timing filled in by PublishRecord).
void Channel::Record(const IoTime& io, const ControllerOutput& out, IoStatus write) {
  record_.period = stats_.ticks - 1;
  record_.t_ns = io.loop_ns;
  record_.latency_ns = 0;
  record_.exec_ns = 0;
  record_.frame = frame_;
  record_.read = read_;
  record_.write = write;
  record_.v_used = controller_->v_used();
  record_.x_used = controller_->x_used();
  record_.e_law = controller_->law_volts();
  record_.model_force = out.model_force;
  record_.force_demand = out.force_demand;
  // A failed command was followed by the safe voltage (Finish).
  record_.command_v =
      !out.safe && write == IoStatus::kFault ? controller_->config().safe_voltage : out.volts;
  record_.force_law = out.force_law;
  record_.reachable = out.reachable;
  record_.passive = out.force_law && out.passive;
  record_.non_monotone = out.force_law && !out.monotone;
  record_.safe = out.safe;
  record_.causes = out.causes;
  record_.param_version = hook_ != nullptr ? hook_->version() : 0;
}

void Channel::PublishRecord(std::int64_t latency_ns, std::int64_t exec_ns) {
  if (observer_ == nullptr) return;
  record_.latency_ns = latency_ns;
  record_.exec_ns = exec_ns;
  observer_->OnPeriod(record_);
}

void Channel::Shutdown(const IoTime& t, const LoopTiming& timing) {
  if (driver_.EnterSafeState(t, controller_->config().safe_voltage) == IoStatus::kFault) {
    ++stats_.write_faults;
  }
  CopyTiming(timing, &stats_);
  stats_.safe = true;
  stats_.last_command_v = controller_->config().safe_voltage;
  telemetry_.Write(stats_);
}

std::uint32_t Channel::own_causes() const {
  return stats_.active_causes & ~Watchdog::Bit(FaultCause::kOtherChannel);
}

}  // namespace mrd::firmware
