// The scenario run's last phase (run_session.hpp): the firmware stopped and its summary read,
// the ports closed and counted, the run scored and judged.
#include <algorithm>
#include <cstdlib>

#include "run_internal.hpp"
#include "run_session.hpp"

namespace mrd::hil {
namespace {

RideFigures Figures(const RideMetrics& m) {
  return {m.count(),           m.body_accel_rms(), m.travel_rms_cm(),
          m.tyre_load_rms_n(), m.max_travel_cm(),  m.lift_off()};
}

}  // namespace

int ScenarioRun::Teardown() {
  const RunOptions& o = o_;
  const Scenario& s = s_;
  const std::int64_t wall1 = common::MonotonicNs();
  r_->wall_s = static_cast<double>(wall1 - wall0_) * 1e-9;
  r_->speed_x = r_->wall_s > 0.0 ? static_cast<double>(r_->steps) * 1e-3 / r_->wall_s : 0.0;
  r_->latency = Summarise(std::move(latency_us_));
  r_->wake_jitter = Summarise(std::move(jitter_us_));
  if (!o.attach) StopFirmware();
  if (port_open_) port_->Close();
  PortCounters counters = port_->counters();
  // Start-up offers repeated for a firmware not on the bus yet are no steps (their number
  // depends on wall time: lockstep summaries must not).
  counters.published -= std::min(counters.published, reoffers_);
  r_->ports.emplace_back(port_->name(), counters);
  if (score_ride_) r_->ride = RideScores{Figures(ride_), Figures(ride_off_), Figures(ride_on_)};
  if (score_floors_) {
    r_->structure = StructureScores{floors_.Figures(), floors_off_.Figures(), floors_on_.Figures()};
  }
  if (plant_->Holds() != nullptr) r_->plant_holds = *plant_->Holds();
  if (gpio_.active()) {
    gpio_.Close();
    r_->ports.emplace_back(gpio_.name(), gpio_.counters());
  }
  if (pwm_.active()) {
    r_->ports.emplace_back(pwm_.name(), pwm_.counters());
    pwm_.Close();
  }
  ScoreRun(s, r_);
  if (replaying_ && o.keep_trace) r_->replay = ScoreReplay(r_->trace, replay_);
  EvaluatePass(s, r_);
  return 0;
}

// Stop the firmware: in lockstep it ends by itself after its duration; else SIGTERM. Its exit,
// summary (missed grants) and stderr into the result.
void ScenarioRun::StopFirmware() {
  if (fw_.Alive()) {
    if (lockstep_) {
      // Its last tick may still wait for a grant: one more ends it.
      port_->SendGrant((steps_ + 1) * kPeriodNs);
      const std::int64_t until =
          common::MonotonicNs() + static_cast<std::int64_t>(o_.command_timeout_s * 1e9);
      while (fw_.Alive() && common::MonotonicNs() < until) Pump(2'000'000);
      if (fw_.Alive()) fw_.Stop(2.0);
    } else {
      fw_.Stop(2.0);
    }
  }
  r_->firmware_exit = fw_.status();
  const std::string tag = Tag(r_->firmware_starts - 1);
  ReadFile(o_.work_dir + "/firmware" + tag + ".json", &r_->firmware_json);
  ReadFile(o_.work_dir + "/firmware" + tag + ".err", &r_->firmware_stderr);
  const auto at = r_->firmware_json.find("\"missed_grants\":");
  if (at != std::string::npos) {
    r_->missed_grants = std::strtoull(r_->firmware_json.c_str() + at + 16, nullptr, 10);
  }
}

}  // namespace mrd::hil
