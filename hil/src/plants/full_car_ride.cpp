// A full car's ride figures and runs (full_car_ride.hpp).
#include "mrd/hil/plants/full_car_ride.hpp"

#include <algorithm>
#include <cmath>

namespace mrd::hil {

double FullCarRidePoint::worst_tyre_load_rms_n() const {
  return *std::max_element(tyre_load_rms_n.begin(), tyre_load_rms_n.end());
}

double MetricOf(const FullCarRidePoint& p, FullCarMetric m) {
  switch (m) {
    case FullCarMetric::kBodyAccel:
      return p.body_accel_rms;
    case FullCarMetric::kBodyAccelWk:
      return p.body_accel_wk_rms;
    case FullCarMetric::kPitchRate:
      return p.pitch_rate_rms;
    case FullCarMetric::kRollRate:
      return p.roll_rate_rms;
    case FullCarMetric::kTyreLoad:
      return p.worst_tyre_load_rms_n();
  }
  return 0.0;
}

FullCarScorer::FullCarScorer(double settle_s, double fs_hz) : settle_s_(settle_s), wk_(fs_hz) {}

void FullCarScorer::Add(const FullCarSample& s) {
  const double wk = wk_.Step(s.heave_accel);
  if (s.t_s <= settle_s_) return;
  ++n_;
  acc2_ += s.heave_accel * s.heave_accel;
  wk2_ += wk * wk;
  pitch2_ += s.pitch_rate * s.pitch_rate;
  roll2_ += s.roll_rate * s.roll_rate;
  for (int i = 0; i < 4; ++i) {
    tyre2_[i] += s.corner[i].tyre_load_n * s.corner[i].tyre_load_n;
    lift_off_ += s.corner[i].airborne ? 1 : 0;
  }
}

FullCarRidePoint FullCarScorer::Point() const {
  FullCarRidePoint p;
  if (n_ == 0) return p;
  const double n = static_cast<double>(n_);
  p.body_accel_rms = std::sqrt(acc2_ / n);
  p.body_accel_wk_rms = std::sqrt(wk2_ / n);
  p.pitch_rate_rms = std::sqrt(pitch2_ / n);
  p.roll_rate_rms = std::sqrt(roll2_ / n);
  for (int i = 0; i < 4; ++i) p.tyre_load_rms_n[i] = std::sqrt(tyre2_[i] / n);
  p.samples = n_;
  p.lift_off = lift_off_;
  return p;
}

FullCarRidePoint RunFullCarRide(FullCarPlant* plant, double duration_s, double settle_s,
                                const FullCarLaw& law) {
  plant->Reset();
  FullCarScorer scorer(settle_s, 1.0 / plant->period_s());
  const auto steps = static_cast<std::int64_t>(std::llround(duration_s / plant->period_s()));
  double front = 0.0, rear = 0.0;
  CornerValues volts{};
  for (std::int64_t k = 0; k < steps; ++k) {
    law(*plant, k, &volts);
    front += volts[kFrontLeft] + volts[kFrontRight];
    rear += volts[kRearLeft] + volts[kRearRight];
    scorer.Add(plant->Step(volts));
  }
  FullCarRidePoint p = scorer.Point();
  const double n = 2.0 * static_cast<double>(std::max<std::int64_t>(steps, 1));
  p.volts_front = front / n;
  p.volts_rear = rear / n;
  return p;
}

std::vector<FullCarRidePoint> RunFullCarGrid(
    FullCarPlant* plant, double duration_s, double settle_s,
    const std::vector<std::pair<double, double>>& front_rear_volts) {
  std::vector<FullCarRidePoint> out;
  out.reserve(front_rear_volts.size());
  for (const auto& [front, rear] : front_rear_volts) {
    const CornerValues held{front, front, rear, rear};
    out.push_back(
        RunFullCarRide(plant, duration_s, settle_s,
                       [&held](const FullCarPlant&, std::int64_t, CornerValues* v) { *v = held; }));
    out.back().volts_front = front;  // exact (the mean of the held command rounds)
    out.back().volts_rear = rear;
  }
  return out;
}

std::size_t BestFullCarPoint(const std::vector<FullCarRidePoint>& points, FullCarMetric m) {
  std::size_t best = 0;
  for (std::size_t i = 1; i < points.size(); ++i) {
    if (MetricOf(points[i], m) < MetricOf(points[best], m)) best = i;
  }
  return best;
}

std::optional<std::size_t> BestFullCarAtHolding(const std::vector<FullCarRidePoint>& points,
                                                double tyre_limit_n, FullCarMetric m) {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (points[i].worst_tyre_load_rms_n() > tyre_limit_n) continue;
    if (!best || MetricOf(points[i], m) < MetricOf(points[*best], m)) best = i;
  }
  return best;
}

}  // namespace mrd::hil
