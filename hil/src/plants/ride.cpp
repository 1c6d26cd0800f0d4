// A quarter car's ride figures and the passive comparison's arithmetic (ride.hpp).
#include "mrd/hil/plants/ride.hpp"

#include <algorithm>
#include <cmath>

namespace mrd::hil {
namespace {

constexpr std::size_t kMaxGridPoints = 100000;

}  // namespace

const char* RideMetricKey(RideMetric m) {
  switch (m) {
    case RideMetric::kBodyAccel:
      return "body_accel_rms";
    case RideMetric::kBodyAccelWk:
      return "body_accel_wk_rms";
    case RideMetric::kTyreLoad:
      return "tyre_load_rms_n";
    case RideMetric::kTravel:
      return "travel_rms_cm";
  }
  return "?";
}

const char* RideMetricTitle(RideMetric m) {
  switch (m) {
    case RideMetric::kBodyAccel:
      return "body acceleration RMS [m/s^2]";
    case RideMetric::kBodyAccelWk:
      return "body acceleration RMS, ISO 2631-1 Wk weighted [m/s^2]";
    case RideMetric::kTyreLoad:
      return "tyre load RMS [N]";
    case RideMetric::kTravel:
      return "suspension travel RMS [cm]";
  }
  return "?";
}

double MetricOf(const RidePoint& p, RideMetric m) {
  switch (m) {
    case RideMetric::kBodyAccel:
      return p.body_accel_rms;
    case RideMetric::kBodyAccelWk:
      return p.body_accel_wk_rms;
    case RideMetric::kTyreLoad:
      return p.tyre_load_rms_n;
    case RideMetric::kTravel:
      return p.travel_rms_cm;
  }
  return 0.0;
}

RideScorer::RideScorer(double settle_s, double fs_hz) : settle_s_(settle_s), wk_(fs_hz) {}

void RideScorer::Add(const QuarterCarSample& s) {
  AddWk(s.plant.t_s, s.body_accel);
  if (s.plant.t_s > settle_s_) ride_.Add(s);
}

void RideScorer::AddWk(double t_s, double body_accel) {
  const double w = wk_.Step(body_accel);
  if (t_s > settle_s_) {
    wk2_ += w * w;
    ++wk_n_;
  }
}

double RideScorer::wk_rms() const {
  return wk_n_ > 0 ? std::sqrt(wk2_ / static_cast<double>(wk_n_)) : 0.0;
}

RidePoint RideScorer::Point() const {
  RidePoint p;
  p.body_accel_rms = ride_.body_accel_rms();
  p.body_accel_wk_rms = wk_rms();
  p.tyre_load_rms_n = ride_.tyre_load_rms_n();
  p.travel_rms_cm = ride_.travel_rms_cm();
  p.samples = ride_.count();
  p.lift_off = ride_.lift_off();
  return p;
}

RidePoint RunRide(QuarterCarPlant* plant, double duration_s, double settle_s, const RideLaw& law,
                  std::vector<double>* accel) {
  plant->Reset();
  RideScorer scorer(settle_s, 1.0 / plant->period_s());
  const auto steps = static_cast<std::int64_t>(std::llround(duration_s / plant->period_s()));
  double volts_sum = 0.0;
  for (std::int64_t k = 0; k < steps; ++k) {
    const double v = law(plant->Sample(), k);
    volts_sum += v;
    plant->Step(v);
    const QuarterCarSample& d = plant->Detail();
    scorer.Add(d);
    if (accel != nullptr && d.plant.t_s > settle_s) accel->push_back(d.body_accel);
  }
  RidePoint p = scorer.Point();
  p.volts = steps > 0 ? volts_sum / static_cast<double>(steps) : 0.0;
  return p;
}

bool GridVoltages(double lo, double hi, double step, std::vector<double>* out, std::string* error) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || !std::isfinite(step) || !(step > 0.0)) {
    *error = "the passive grid needs a finite step > 0 V";
    return false;
  }
  if (lo > hi) {
    *error = "the passive grid's lowest voltage is above its highest";
    return false;
  }
  if ((hi - lo) / step > static_cast<double>(kMaxGridPoints)) {
    *error = "the passive grid step is too small (more than 100000 points)";
    return false;
  }
  out->clear();
  for (std::size_t i = 0;; ++i) {
    const double v = lo + static_cast<double>(i) * step;
    if (v > hi + 1e-9) break;
    out->push_back(std::min(v, hi));
  }
  if (hi - out->back() > 1e-9) out->push_back(hi);
  return true;
}

PassiveBest BestOf(const std::vector<RidePoint>& points, RideMetric m) {
  PassiveBest b;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double v = MetricOf(points[i], m);
    if (i == 0 || v < b.value) b = {i, points[i].volts, v};
  }
  return b;
}

std::optional<PassiveBest> BestComfortAtRoadHolding(const std::vector<RidePoint>& points,
                                                    double tyre_limit_n, RideMetric m) {
  std::optional<PassiveBest> b;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!(points[i].tyre_load_rms_n <= tyre_limit_n)) continue;
    const double v = MetricOf(points[i], m);
    if (!b || v < b->value) b = PassiveBest{i, points[i].volts, v};
  }
  return b;
}

double ImprovementPercent(double best, double value) {
  return best != 0.0 ? 100.0 * (best - value) / best : 0.0;
}

PassiveComparison Compare(const std::vector<RidePoint>& grid, const RidePoint& controlled) {
  PassiveComparison c;
  for (std::size_t i = 0; i < kNumRideMetrics; ++i) {
    c.best[i] = BestOf(grid, kRideMetrics[i]);
    c.improvement[i] = ImprovementPercent(c.best[i].value, MetricOf(controlled, kRideMetrics[i]));
  }
  c.comfort_at_holding = BestComfortAtRoadHolding(grid, controlled.tyre_load_rms_n);
  if (c.comfort_at_holding) {
    c.comfort_at_holding_improvement =
        ImprovementPercent(c.comfort_at_holding->value, controlled.body_accel_rms);
  }
  c.wk_at_holding =
      BestComfortAtRoadHolding(grid, controlled.tyre_load_rms_n, RideMetric::kBodyAccelWk);
  if (c.wk_at_holding) {
    c.wk_at_holding_improvement =
        ImprovementPercent(c.wk_at_holding->value, controlled.body_accel_wk_rms);
  }
  return c;
}

Psd BodyAccelPsd(const std::vector<double>& accel, double fs_hz) {
  Psd psd;
  if (accel.size() < 32) return psd;
  std::size_t seg = 4096;
  while (seg > 8 && seg * 4 > accel.size()) seg /= 2;
  WelchPsd(accel, fs_hz, seg, &psd);
  return psd;
}

}  // namespace mrd::hil
