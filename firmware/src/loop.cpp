#include "mrd/firmware/loop.hpp"

#include "mrd/common/clock.hpp"

namespace mrd::firmware {

Loop::Loop(Clock& clock, SensorSource& source, CurrentDriver& driver, Controller& controller,
           Telemetry& telemetry, std::int64_t period_ns)
    : clock_(clock), period_ns_(period_ns) {
  own_.emplace(source, driver, controller, telemetry);
  if (period_ns <= 0) return;
  channels_[0] = &*own_;
  frames_[0] = &own_->frame();
  count_ = 1;
}

Loop::Loop(Clock& clock, Channel* const* channels, std::size_t n, FaultPolicy policy,
           std::int64_t period_ns)
    : clock_(clock), policy_(policy), period_ns_(period_ns) {
  if (n == 0 || n > kMaxChannels || channels == nullptr || period_ns <= 0) return;
  for (std::size_t i = 0; i < n; ++i) {
    if (channels[i] == nullptr) return;
  }
  count_ = n;
  for (std::size_t i = 0; i < count_; ++i) {
    channels_[i] = channels[i];
    frames_[i] = &channels[i]->frame();
  }
}

namespace {

// What a loop that is not ok reports: a channel that never ran.
struct Idle {
  TelemetrySnapshot stats;
  Controller controller;
};

const Idle& IdleChannel() {
  static const Idle idle;
  return idle;
}

}  // namespace

const TelemetrySnapshot& Loop::stats() const {
  return ok() ? channels_[0]->stats() : IdleChannel().stats;
}

const Controller& Loop::controller() const {
  return ok() ? channels_[0]->controller() : IdleChannel().controller;
}

void Loop::SetHook(PeriodHook* hook) {
  if (ok()) channels_[0]->SetHook(hook);
}

void Loop::SetObserver(PeriodObserver* observer) {
  if (ok()) channels_[0]->SetObserver(observer);
}

void Loop::Tick(std::int64_t now_ns) {
  Tick(IoTime{now_ns, clock_.IsMonotonic() ? now_ns : common::MonotonicNs()});
}

void Loop::Tick(const IoTime& io) {
  const std::int64_t now_ns = io.loop_ns;
  // Period boundaries and reads, then what is computed over all channels.
  for (std::size_t i = 0; i < count_; ++i) channels_[i]->Begin(io);
  if (body_law_ != nullptr) body_law_->Apply(frames_.data(), count_, now_ns);

  // Clamp dt to [period / 2, 2 period].
  const std::int64_t dt_ns = first_tick_ ? period_ns_ : now_ns - last_tick_ns_;
  const std::int64_t clamped =
      dt_ns < period_ns_ / 2 ? period_ns_ / 2 : (dt_ns > 2 * period_ns_ ? 2 * period_ns_ : dt_ns);
  first_tick_ = false;
  last_tick_ns_ = now_ns;
  const double dt_s = static_cast<double>(clamped) * 1e-9;

  // Update, write, count; the peers' faults of the last period under FaultPolicy::kAll.
  std::uint32_t faulted = 0;
  for (std::size_t i = 0; i < count_; ++i) {
    const std::uint32_t others = faulted_ & ~(1U << i);
    channels_[i]->Finish(io, dt_s, policy_ == FaultPolicy::kAll && others != 0, timing_, in_run_);
    if (channels_[i]->own_causes() != 0) faulted |= 1U << i;
  }
  faulted_ = faulted;
}

void Loop::Shutdown() {
  // After the last period: the loop's time stays that period's; the wall clock is read now.
  Shutdown(IoTime{last_tick_ns_, common::MonotonicNs()});
}

void Loop::Shutdown(const IoTime& t) {
  for (std::size_t i = 0; i < count_; ++i) channels_[i]->Shutdown(t, timing_);
}

void Loop::Run(const std::atomic<bool>& stop, std::int64_t duration_ns) {
  if (!ok()) return;  // no channel, no driver to leave safe
  const std::int64_t start = clock_.Now();
  std::int64_t deadline = start + period_ns_;
  while (!stop.load(std::memory_order_relaxed) &&
         (duration_ns <= 0 || deadline - start <= duration_ns)) {
    clock_.SleepUntil(deadline);
    if (clock_.Halted()) break;  // lockstep without a harness: no time, no tick
    const std::int64_t wake = clock_.Now();
    const std::int64_t latency = wake - deadline;
    if (latency > timing_.worst_latency_ns) timing_.worst_latency_ns = latency;
    in_run_ = true;
    Tick(wake);
    in_run_ = false;
    const std::int64_t end = clock_.Now();
    timing_.last_exec_ns = end - wake;
    for (std::size_t i = 0; i < count_; ++i) {
      channels_[i]->PublishRecord(latency, timing_.last_exec_ns);
    }
    if (timing_.last_exec_ns > timing_.worst_exec_ns) timing_.worst_exec_ns = timing_.last_exec_ns;
    deadline += period_ns_;
    // A clock behind its deadline re-aligns on its own time (never with CLOCK_MONOTONIC,
    // where end >= the previous deadline).
    if (end + period_ns_ < deadline) deadline = end + period_ns_;
    // A late wake-up that ends exactly on the next deadline skips it too: that period's tick
    // would otherwise run at once on the same time (lockstep: two ticks on one grant after the
    // harness's time jumped). Work of exactly one period after an on-time wake-up is not an
    // overrun.
    if (end > deadline || (end == deadline && latency > 0)) {
      ++timing_.overruns;
      const std::int64_t missed = (end - deadline) / period_ns_ + 1;
      timing_.missed_periods += static_cast<std::uint64_t>(missed);
      deadline += missed * period_ns_;
    }
  }
  Shutdown();
}

}  // namespace mrd::firmware
