// Scores and pass criteria of a scenario run (run.hpp).
#include <algorithm>
#include <cmath>
#include <sstream>

#include "run_internal.hpp"

namespace mrd::hil {
namespace {

double Ratio(double num, double den) { return den > 0.0 ? std::sqrt(num / den) : 0.0; }

std::string Fmt(double v) {
  std::ostringstream s;
  s.precision(4);
  s << v;
  return s.str();
}

}  // namespace

void ScoreRun(const Scenario& s, RunResult* r) {
  // Tracking over the controlled steps (coil driven by a non-safe command).
  double e2 = 0, d2 = 0, off2 = 0, on2 = 0, er2 = 0, dr2 = 0, offr2 = 0, onr2 = 0, f2 = 0;
  TrackingScores& t = r->tracking;
  for (const StepRecord& k : r->trace) {
    if (!k.driven || k.safe) continue;
    ++t.steps;
    const double e = k.force - k.demand, eo = k.force_off - k.demand, en = k.force_on - k.demand;
    e2 += e * e;
    d2 += k.demand * k.demand;
    off2 += eo * eo;
    on2 += en * en;
    f2 += k.force * k.force;
    if (k.reachable) {
      ++t.reachable_steps;
      er2 += e * e;
      dr2 += k.demand * k.demand;
      offr2 += eo * eo;
      onr2 += en * en;
    }
  }
  t.error_all = Ratio(e2, d2);
  t.off_all = Ratio(off2, d2);
  t.on_all = Ratio(on2, d2);
  t.error_reachable = Ratio(er2, dr2);
  t.all_scored = d2 > 0.0;
  t.reachable_scored = dr2 > 0.0;
  t.off_reachable = Ratio(offr2, dr2);
  t.on_reachable = Ratio(onr2, dr2);
  if (t.steps > 0) {
    t.reachable_share = static_cast<double>(t.reachable_steps) / static_cast<double>(t.steps);
    t.rms_force_n = std::sqrt(f2 / static_cast<double>(t.steps));
    t.rms_demand_n = std::sqrt(d2 / static_cast<double>(t.steps));
  }

  // Per fault: detection, safe state, recovery (in periods).
  const auto n = static_cast<std::int64_t>(r->trace.size());
  for (const Fault& f : s.faults) {
    if (f.kind == FaultKind::kCorruptTable) continue;
    FaultResult fr;
    fr.fault = f;
    fr.onset_step = static_cast<std::int64_t>(std::llround(f.at_s / 1e-3));
    fr.clear_step =
        f.duration_s > 0.0
            ? fr.onset_step + static_cast<std::int64_t>(std::llround(f.duration_s / 1e-3))
            : n;
    // A delay shorter than the firmware's max_age cannot be seen: the data are late, not stale.
    // A delay shorter than the firmware's max_age cannot be seen: the data are late, not
    // stale. A killed plant side cannot watch the firmware detect its absence: the firmware's
    // missed grants / stale causes show it (its summary), the harness checks that the first
    // command it hears after the restart is the safe state.
    fr.detection_required =
        !(f.kind == FaultKind::kDelay && f.delay_periods <= static_cast<int>(s.max_age_ms)) &&
        f.kind != FaultKind::kKillPlant;
    const bool driver_side = f.kind == FaultKind::kKillFirmware;
    // Detection belongs to this fault only before the next fault starts (a later fault's
    // detection must not count for one that went unseen).
    std::int64_t window_end = n;
    for (const Fault& g : s.faults) {
      const auto g0 = static_cast<std::int64_t>(std::llround(g.at_s / 1e-3));
      if (g0 > fr.onset_step && g0 < window_end) window_end = g0;
    }
    for (std::int64_t k = fr.onset_step; k < window_end; ++k) {
      const StepRecord& rec = r->trace[static_cast<std::size_t>(k)];
      const bool detected = driver_side ? !rec.driven : rec.causes != 0;
      const bool safe = driver_side ? !rec.driven : (rec.safe || !rec.driven);
      if (!fr.detection && detected) fr.detection = k - fr.onset_step;
      if (!fr.safe && safe) fr.safe = k - fr.onset_step;
      if (fr.detection && fr.safe) break;
    }
    const std::int64_t from = fr.clear_step + 0;
    for (std::int64_t k = from; k < n && fr.safe; ++k) {
      const StepRecord& rec = r->trace[static_cast<std::size_t>(k)];
      if (k - fr.onset_step < *fr.safe) continue;
      if (rec.driven && !rec.safe) {
        fr.recovery = k - fr.clear_step;
        break;
      }
    }
    const bool clears = fr.clear_step < n;
    if (f.kind == FaultKind::kKillPlant && clears) {
      const auto back = static_cast<std::size_t>(fr.clear_step);
      if (!r->trace[back].safe && r->trace[back].driven) {
        fr.ok = false;
        fr.why = "the first command after the plant side came back was not the safe state";
      }
    }
    if (!fr.ok) {
    } else if (fr.detection_required && !fr.detection) {
      fr.ok = false;
      fr.why = "never detected";
    } else if (fr.detection && !fr.safe) {
      fr.ok = false;
      fr.why = "detected but never in the safe state";
    } else if (fr.detection && *fr.safe - *fr.detection > s.max_detection_to_safe_periods) {
      fr.ok = false;
      fr.why = "safe state " + std::to_string(*fr.safe - *fr.detection) +
               " periods after detection (limit " +
               std::to_string(s.max_detection_to_safe_periods) + ")";
    } else if (s.require_recovery && clears && fr.safe && !fr.recovery) {
      fr.ok = false;
      fr.why = "no recovery after the fault cleared";
    }
    r->faults.push_back(fr);
  }
}

void EvaluatePass(const Scenario& s, RunResult* r) {
  auto& f = r->failures;
  if (r->invariant_violations > s.max_invariant_violations) {
    f.push_back("invariant violations " + std::to_string(r->invariant_violations) + " > " +
                std::to_string(s.max_invariant_violations));
  }
  const bool table_only = !s.faults.empty() && s.faults.front().kind == FaultKind::kCorruptTable;
  if (!table_only) {
    // A NaN error (a diverged plant) fails; so does an error with nothing to normalise it by
    // (no reachable step, or a zero demand): 0/0 is no score.
    const TrackingScores& t = r->tracking;
    if (s.max_error_reachable && !(t.error_reachable <= *s.max_error_reachable)) {
      f.push_back("tracking error on reachable demands " + Fmt(t.error_reachable) + " > " +
                  Fmt(*s.max_error_reachable));
    }
    if (s.max_error_reachable && t.steps > 0 && t.reachable_share < s.min_reachable_share) {
      f.push_back("reachable demands on " + Fmt(100.0 * t.reachable_share) + " % of the " +
                  std::to_string(t.steps) + " controlled steps < min_reachable_share " +
                  Fmt(100.0 * s.min_reachable_share) +
                  " %: the reachable error scores too little of the run (error over all "
                  "steps " +
                  Fmt(t.error_all) + ")");
    }
    if (s.max_error_all && !(t.error_all <= *s.max_error_all)) {
      f.push_back("tracking error " + Fmt(t.error_all) + " > " + Fmt(*s.max_error_all));
    }
    if ((s.max_error_reachable || s.max_error_all) && t.steps == 0) {
      f.push_back("no controlled step to score");
    } else if ((s.max_error_all && !t.all_scored) ||
               (s.max_error_reachable && !t.reachable_scored)) {
      f.push_back("no non-zero demand to score the tracking error on");
    }
    if (r->commands == 0) f.push_back("no command from the firmware");
    if (s.max_missed_grants && r->clock == "lockstep") {
      if (!r->missed_grants) {
        f.push_back("no firmware summary to count missed grants");
      } else if (*r->missed_grants > *s.max_missed_grants) {
        f.push_back("missed grants " + std::to_string(*r->missed_grants) + " > " +
                    std::to_string(*s.max_missed_grants));
      }
    }
  }
  if (s.body_accel_below_passive && !table_only) {
    if (!r->ride || r->ride->controlled.samples == 0) {
      f.push_back("no ride figures to compare (quarter car)");
    } else {
      const RideScores& ride = *r->ride;
      const double best_passive =
          std::min(ride.passive_off.body_accel_rms, ride.passive_on.body_accel_rms);
      if (!(ride.controlled.body_accel_rms < best_passive)) {
        f.push_back("body acceleration RMS " + Fmt(ride.controlled.body_accel_rms) +
                    " m/s^2 not below the better passive case " + Fmt(best_passive));
      }
    }
  }
  if (s.tyre_load_below_passive_off && !table_only) {
    if (!r->ride || r->ride->controlled.samples == 0) {
      f.push_back("no ride figures to compare (quarter car)");
    } else if (!(r->ride->controlled.tyre_load_rms_n < r->ride->passive_off.tyre_load_rms_n)) {
      f.push_back("tyre load RMS " + Fmt(r->ride->controlled.tyre_load_rms_n) +
                  " N not below passive-off's " + Fmt(r->ride->passive_off.tyre_load_rms_n));
    }
  }
  const bool floors_needed =
      s.peak_drift_below_passive_on || s.peak_accel_below_passive_on || s.max_peak_force_n;
  if (floors_needed && !table_only) {
    if (!r->structure || r->structure->controlled.samples == 0) {
      f.push_back("no structure figures to compare (structure)");
    } else {
      const StructureScores& st = *r->structure;
      if (s.peak_drift_below_passive_on &&
          !(st.controlled.peak_drift_cm() <= st.passive_on.peak_drift_cm())) {
        f.push_back("peak drift " + Fmt(st.controlled.peak_drift_cm()) + " cm above passive-on's " +
                    Fmt(st.passive_on.peak_drift_cm()));
      }
      if (s.peak_accel_below_passive_on &&
          !(st.controlled.peak_accel_cm_s2() <= st.passive_on.peak_accel_cm_s2())) {
        f.push_back("peak floor acceleration " + Fmt(st.controlled.peak_accel_cm_s2()) +
                    " cm/s^2 above passive-on's " + Fmt(st.passive_on.peak_accel_cm_s2()));
      }
      if (s.max_peak_force_n && !(st.controlled.peak_force_n <= *s.max_peak_force_n)) {
        f.push_back("peak damper force " + Fmt(st.controlled.peak_force_n) + " N > " +
                    Fmt(*s.max_peak_force_n));
      }
    }
  }
  for (const FaultResult& fr : r->faults) {
    if (!fr.ok)
      f.push_back(std::string("fault ") + FaultKindName(fr.fault.kind) + " at " +
                  Fmt(fr.fault.at_s) + " s: " + fr.why);
  }
  if (s.min_replay_fit && (!r->replay || r->replay->fit_percent < *s.min_replay_fit)) {
    f.push_back(r->replay ? "replay fit " + Fmt(r->replay->fit_percent) + " % < " +
                                Fmt(*s.min_replay_fit) + " %"
                          : std::string("no replay figures (needs the trace)"));
  }
  r->pass = f.empty();
}

ReplayScores ScoreReplay(const std::vector<StepRecord>& trace, const ReplayRun& run) {
  ReplayScores s;
  const std::size_t n = std::min(trace.size(), run.f.size() > 0 ? run.f.size() - 1 : 0);
  if (n == 0) return s;
  double mean = 0.0;
  for (std::size_t k = 0; k < n; ++k) mean += run.f[k + 1];
  mean /= static_cast<double>(n);
  double e2 = 0.0, d2 = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double e = run.f[k + 1] - trace[k].force;
    e2 += e * e;
    d2 += (run.f[k + 1] - mean) * (run.f[k + 1] - mean);
  }
  s.samples = n;
  s.rmse_n = std::sqrt(e2 / static_cast<double>(n));
  s.fit_percent = d2 > 0.0 ? 100.0 * (1.0 - std::sqrt(e2 / d2)) : 0.0;
  return s;
}

}  // namespace mrd::hil
