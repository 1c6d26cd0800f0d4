#include "mrd/hil/run/serve.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <ctime>

#include "mrd/common/clock.hpp"

namespace mrd::hil {
namespace {}  // namespace

void PlantPort::Wait(std::int64_t timeout_ns) {
  const std::int64_t step = timeout_ns < 200'000 ? timeout_ns : 200'000;
  const timespec ts{0, static_cast<long>(step > 0 ? step : 0)};
  nanosleep(&ts, nullptr);
}

LatencyStats Summarise(std::vector<double> samples_us) {
  LatencyStats s;
  s.count = samples_us.size();
  if (samples_us.empty()) return s;
  std::sort(samples_us.begin(), samples_us.end());
  const auto at = [&](double q) {
    const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(samples_us.size())));
    return samples_us[std::min(samples_us.size() - 1, i == 0 ? 0 : i - 1)];
  };
  s.median_us = at(0.5);
  s.p99_us = at(0.99);
  s.max_us = samples_us.back();
  return s;
}

ServeResult Serve(const ServeOptions& o, const std::vector<PlantPort*>& ports,
                  const std::atomic<bool>& stop) {
  ServeResult r;
  DamperPlant plant(o.params, o.excitation, o.period_s);
  const auto period_ns = static_cast<std::int64_t>(std::llround(o.period_s * 1e9));
  const auto heartbeat_timeout_ns =
      static_cast<std::int64_t>(std::llround(o.heartbeat_timeout_s * 1e9));
  constexpr std::size_t kRing = 4096;
  std::array<std::int64_t, kRing> published_ns{};
  std::array<std::uint32_t, kRing> published_seq{};
  std::vector<double> latency_us;
  latency_us.reserve(o.duration_s > 0.0 ? static_cast<std::size_t>(o.duration_s / o.period_s) + 16
                                        : 1 << 16);

  DriverInput in;
  bool carries_enable = false, carries_heartbeat = false, heartbeat_fresh = false;
  bool have_echo = false;
  std::uint32_t last_echo = 0;
  double set_point = 0.0;
  double sum_f2 = 0.0, sum_e2 = 0.0, sum_d2 = 0.0;
  std::uint32_t seq = 0;
  bool fault_published = false;
  std::uint64_t first_fault_step = 0;

  const std::int64_t start = common::MonotonicNs();
  std::int64_t deadline = start;
  const auto steps_limit = o.duration_s > 0.0
                               ? static_cast<std::uint64_t>(std::llround(o.duration_s / o.period_s))
                               : UINT64_MAX;
  PlantSample sample = plant.Sample();
  while (!stop.load(std::memory_order_relaxed) && r.steps < steps_limit) {
    (void)common::SleepUntilNs(deadline);
    const std::int64_t now = common::MonotonicNs();
    if (now - deadline > period_ns) ++r.late_steps;

    // Hear the firmware.
    DriverInput fresh = in;
    fresh.has_command = false;
    fresh.has_echo = false;
    for (PlantPort* p : ports) p->Poll(&fresh);
    if (fresh.has_command) {
      ++r.commands;
      set_point = fresh.volts;
      if (!std::isfinite(fresh.volts) || fresh.volts < 0.0 || fresh.volts > o.e_max) {
        ++r.invariant_violations;
      }
    }
    if (fresh.has_echo && (!have_echo || fresh.echo != last_echo)) {
      have_echo = true;
      last_echo = fresh.echo;
      const std::size_t slot = fresh.echo % kRing;
      if (published_seq[slot] == fresh.echo && published_ns[slot] != 0) {
        latency_us.push_back(static_cast<double>(fresh.command_ns - published_ns[slot]) * 1e-3);
      }
    }
    if (carries_enable && in.enable && fresh.has_enable && !fresh.enable) ++r.enable_falls;
    carries_enable = carries_enable || fresh.has_enable;
    carries_heartbeat = carries_heartbeat || fresh.heartbeat_ns != 0;
    in = fresh;

    // The simulated current driver.
    const bool fresh_hb = !carries_heartbeat || now - in.heartbeat_ns <= heartbeat_timeout_ns;
    if (heartbeat_fresh && !fresh_hb) ++r.heartbeat_timeouts;
    heartbeat_fresh = fresh_hb;
    const bool driven = (!carries_enable || in.enable) && fresh_hb;
    double applied = 0.0;
    if (driven && std::isfinite(set_point)) applied = std::clamp(set_point, 0.0, o.e_max);
    r.last_applied_v = applied;
    // The fault line this step publishes; the driver's state while the one published by the
    // previous step (which the firmware has had a period to see) was asserted.
    const double t_s = static_cast<double>(r.steps) * o.period_s;
    const bool fault_line = o.fault_start_s >= 0.0 && t_s >= o.fault_start_s && t_s < o.fault_end_s;
    if (fault_published) {
      if (driven) {
        ++r.fault_driven_steps;
      } else if (r.fault_reaction_steps == 0) {
        r.fault_reaction_steps = r.steps - first_fault_step;
      }
    }
    if (fault_line) {
      if (r.fault_steps++ == 0) first_fault_step = r.steps;
    } else if (o.fault_start_s >= 0.0 && t_s >= o.fault_end_s && driven) {
      ++r.driven_after_fault_steps;
    }
    fault_published = fault_line;

    // Step the plant and publish.
    sample = plant.Step(applied);
    ++r.steps;
    sum_f2 += sample.force * sample.force;
    if (driven) {
      ++r.enabled_steps;
      sum_e2 += (sample.force - sample.demand) * (sample.force - sample.demand);
      sum_d2 += sample.demand * sample.demand;
    }
    ++seq;
    SensorOutput out;
    out.sample = sample;
    out.seq = seq;
    out.fault_line = fault_line;
    out.t_ns = common::MonotonicNs();
    published_seq[seq % kRing] = seq;
    published_ns[seq % kRing] = out.t_ns;
    for (PlantPort* p : ports) p->Publish(out);

    deadline += period_ns;
  }
  r.rms_force_n = r.steps > 0 ? std::sqrt(sum_f2 / static_cast<double>(r.steps)) : 0.0;
  if (r.enabled_steps > 0) {
    r.rms_tracking_error_n = std::sqrt(sum_e2 / static_cast<double>(r.enabled_steps));
    r.normalised_tracking_error = sum_d2 > 0.0 ? std::sqrt(sum_e2 / sum_d2) : 0.0;
  }
  r.latency = Summarise(std::move(latency_us));
  for (PlantPort* p : ports) r.ports.emplace_back(p->name(), p->counters());
  return r;
}

}  // namespace mrd::hil
