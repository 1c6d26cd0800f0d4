// The best passive baseline of a quarter car (passive_baseline.hpp).
#include "mrd/hil/study/passive_baseline.hpp"

#include <algorithm>
#include <cmath>

#include "mrd/hil/run/run.hpp"
#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil {
namespace {

constexpr double kPeriod = 1e-3;  // [s], the harness's period

}  // namespace

QuarterCarPlant MakeQuarterCar(const Scenario& s) {
  return QuarterCarPlant(s.damper, s.car, s.road, kPeriod);
}

std::vector<RidePoint> RunPassiveGrid(const Scenario& s, double step_v,
                                      const GridProgress& progress) {
  std::vector<double> volts;
  std::string error;
  if (!GridVoltages(0.0, s.e_max, step_v, &volts, &error)) return {};
  QuarterCarPlant plant = MakeQuarterCar(s);
  std::vector<RidePoint> points;
  points.reserve(volts.size());
  for (std::size_t i = 0; i < volts.size(); ++i) {
    const double v = volts[i];
    points.push_back(RunRide(&plant, s.duration_s, s.ride_settle_s,
                             [v](const PlantSample&, std::int64_t) { return v; }));
    points.back().volts = v;  // exact (the mean of the held command rounds)
    if (progress && !progress(i + 1, volts.size())) return {};
  }
  return points;
}

bool ComputePassiveBaseline(const Scenario& s, const RunResult& r, double step_v,
                            PassiveBaseline* out, const GridProgress& progress) {
  if (!r.ride || r.trace.empty()) return false;
  PassiveBaseline b;
  b.step_v = step_v;
  b.grid = RunPassiveGrid(s, step_v, progress);
  if (b.grid.empty()) return false;
  const RideFigures& c = r.ride->controlled;
  b.controlled.body_accel_rms = c.body_accel_rms;
  b.controlled.tyre_load_rms_n = c.tyre_load_rms_n;
  b.controlled.travel_rms_cm = c.travel_rms_cm;
  b.controlled.samples = c.samples;
  b.controlled.lift_off = c.lift_off;
  RideScorer wk(s.ride_settle_s, 1.0 / kPeriod);
  std::vector<double> controlled, off;
  double volts = 0.0;
  for (const StepRecord& k : r.trace) {
    wk.AddWk(k.t, k.body_accel);
    volts += k.applied;
    if (k.t > s.ride_settle_s) {
      controlled.push_back(k.body_accel);
      off.push_back(k.body_accel_off);
    }
  }
  b.controlled.body_accel_wk_rms = wk.wk_rms();
  b.controlled.volts = volts / static_cast<double>(r.trace.size());
  b.comparison = Compare(b.grid, b.controlled);
  // The best passive setting for comfort, run again for its trace.
  const double best_v = b.comparison.best[0].volts;
  QuarterCarPlant plant = MakeQuarterCar(s);
  std::vector<double> best;
  RunRide(
      &plant, s.duration_s, s.ride_settle_s,
      [best_v](const PlantSample&, std::int64_t) { return best_v; }, &best);
  b.psd_off = BodyAccelPsd(off, 1.0 / kPeriod);
  b.psd_best = BodyAccelPsd(best, 1.0 / kPeriod);
  b.psd_controlled = BodyAccelPsd(controlled, 1.0 / kPeriod);
  *out = std::move(b);
  return true;
}

}  // namespace mrd::hil
