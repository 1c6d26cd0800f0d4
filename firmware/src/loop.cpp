#include "mrd/firmware/loop.hpp"

#include <cmath>

#include "mrd/common/clock.hpp"

namespace mrd::firmware {

Loop::Loop(Clock& clock, SensorSource& source, CurrentDriver& driver, Controller& controller,
           Telemetry& telemetry, std::int64_t period_ns)
    : clock_(clock),
      source_(source),
      driver_(driver),
      controller_(&controller),
      telemetry_(telemetry),
      period_ns_(period_ns) {}

void Loop::Tick(std::int64_t now_ns) {
  Tick(IoTime{now_ns, clock_.IsMonotonic() ? now_ns : common::MonotonicNs()});
}

void Loop::Tick(const IoTime& io) {
  const std::int64_t now_ns = io.loop_ns;
  // A period boundary: pending parameter changes and reloads apply here.
  if (hook_ != nullptr) {
    Controller* next = hook_->BeforePeriod(*controller_, stats_.ticks, now_ns);
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
  // Read inputs.
  frame_ = SensorFrame{};
  const IoStatus read = source_.Read(io, &frame_);
  if (read == IoStatus::kFault) ++stats_.read_faults;

  // Clamp dt to [period / 2, 2 period].
  const std::int64_t dt_ns = first_tick_ ? period_ns_ : now_ns - last_tick_ns_;
  const std::int64_t clamped =
      dt_ns < period_ns_ / 2 ? period_ns_ / 2 : (dt_ns > 2 * period_ns_ ? 2 * period_ns_ : dt_ns);
  first_tick_ = false;
  last_tick_ns_ = now_ns;

  // Update.
  const ControllerOutput out =
      controller_->Update(frame_, read, driver_fault_, now_ns, static_cast<double>(clamped) * 1e-9);

  // Write; a failed command falls back to the safe state at once.
  IoStatus write =
      out.safe ? driver_.EnterSafeState(io, out.volts) : driver_.Command(io, out.volts);
  if (write == IoStatus::kFault) {
    ++stats_.write_faults;
    if (!out.safe) (void)driver_.EnterSafeState(io, controller_->config().safe_voltage);
  }
  driver_fault_ = write == IoStatus::kFault;

  // Count and publish.
  ++stats_.ticks;
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
  telemetry_.Write(stats_);
  driver_.PublishStatus(io, stats_);

  // The period's record (timing filled in by Run).
  record_.period = stats_.ticks - 1;
  record_.t_ns = now_ns;
  record_.latency_ns = 0;
  record_.exec_ns = 0;
  record_.frame = frame_;
  record_.read = read;
  record_.write = write;
  record_.v_used = controller_->v_used();
  record_.x_used = controller_->x_used();
  record_.e_law = controller_->law_volts();
  record_.model_force = out.model_force;
  record_.force_demand = out.force_demand;
  // A failed command was followed by the safe voltage (above).
  record_.command_v =
      !out.safe && write == IoStatus::kFault ? controller_->config().safe_voltage : out.volts;
  record_.force_law = out.force_law;
  record_.reachable = out.reachable;
  record_.passive = out.force_law && out.passive;
  record_.non_monotone = out.force_law && !out.monotone;
  record_.safe = out.safe;
  record_.causes = out.causes;
  record_.param_version = hook_ != nullptr ? hook_->version() : 0;
  if (observer_ != nullptr && !in_run_) observer_->OnPeriod(record_);
}

void Loop::Shutdown() {
  // After the last period: the loop's time stays that period's; the wall clock is read now.
  Shutdown(IoTime{last_tick_ns_, common::MonotonicNs()});
}

void Loop::Shutdown(const IoTime& t) {
  if (driver_.EnterSafeState(t, controller_->config().safe_voltage) == IoStatus::kFault) {
    ++stats_.write_faults;
  }
  stats_.safe = true;
  stats_.last_command_v = controller_->config().safe_voltage;
  telemetry_.Write(stats_);
}

void Loop::Run(const std::atomic<bool>& stop, std::int64_t duration_ns) {
  const std::int64_t start = clock_.Now();
  std::int64_t deadline = start + period_ns_;
  while (!stop.load(std::memory_order_relaxed) &&
         (duration_ns <= 0 || deadline - start <= duration_ns)) {
    clock_.SleepUntil(deadline);
    if (clock_.Halted()) break;  // lockstep without a harness: no time, no tick
    const std::int64_t wake = clock_.Now();
    const std::int64_t latency = wake - deadline;
    if (latency > stats_.worst_latency_ns) stats_.worst_latency_ns = latency;
    in_run_ = true;
    Tick(wake);
    in_run_ = false;
    const std::int64_t end = clock_.Now();
    stats_.last_exec_ns = end - wake;
    if (observer_ != nullptr) {
      record_.latency_ns = latency;
      record_.exec_ns = stats_.last_exec_ns;
      observer_->OnPeriod(record_);
    }
    if (stats_.last_exec_ns > stats_.worst_exec_ns) stats_.worst_exec_ns = stats_.last_exec_ns;
    deadline += period_ns_;
    // A clock behind its deadline re-aligns on its own time (never with CLOCK_MONOTONIC,
    // where end >= the previous deadline).
    if (end + period_ns_ < deadline) deadline = end + period_ns_;
    // A late wake-up that ends exactly on the next deadline skips it too: that period's tick
    // would otherwise run at once on the same time (lockstep: two ticks on one grant after the
    // harness's time jumped). Work of exactly one period after an on-time wake-up is not an
    // overrun.
    if (end > deadline || (end == deadline && latency > 0)) {
      ++stats_.overruns;
      const std::int64_t missed = (end - deadline) / period_ns_ + 1;
      stats_.missed_periods += static_cast<std::uint64_t>(missed);
      deadline += missed * period_ns_;
    }
  }
  Shutdown();
}

}  // namespace mrd::firmware
