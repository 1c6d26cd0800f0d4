#pragma once
// A full car's ride figures (the study's metrics), one run of the full-car plant under a law,
// and the best of a set of runs. Scored after the settle time:
//   comfort:      body vertical acceleration RMS at the centre of gravity [m/s^2], plain and
//                 ISO 2631-1 Wk weighted (iso2631_weighting.hpp, the filter from t = 0)
//   attitude:     pitch and roll rate RMS [rad/s]
//   road holding: tyre-load RMS per wheel [N] (corner order of full_car.hpp), and the worst
// Not real-time.

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "mrd/common/iso2631_weighting.hpp"
#include "mrd/hil/plants/full_car_plant.hpp"

namespace mrd::hil {

struct FullCarRidePoint {
  double volts_front = 0.0;     // the held voltage (passive) or the mean command of the front [V]
  double volts_rear = 0.0;      // the same for the rear
  double body_accel_rms = 0.0;  // at the centre of gravity [m/s^2]
  double body_accel_wk_rms = 0.0;  // Wk weighted [m/s^2]
  double pitch_rate_rms = 0.0;     // [rad/s]
  double roll_rate_rms = 0.0;      // [rad/s]
  CornerValues tyre_load_rms_n{};  // per wheel [N]
  std::uint64_t samples = 0;
  std::uint64_t lift_off = 0;  // wheel-samples with a wheel off the ground
  double worst_tyre_load_rms_n() const;
};

enum class FullCarMetric : std::uint8_t {
  kBodyAccel = 0,
  kBodyAccelWk,
  kPitchRate,
  kRollRate,
  kTyreLoad,  // the worst wheel's
};
double MetricOf(const FullCarRidePoint& p, FullCarMetric m);

class FullCarScorer {
 public:
  FullCarScorer(double settle_s, double fs_hz);
  void Add(const FullCarSample& s);
  FullCarRidePoint Point() const;

 private:
  double settle_s_;
  WkFilter wk_;
  std::uint64_t n_ = 0, lift_off_ = 0;
  double acc2_ = 0.0, wk2_ = 0.0, pitch2_ = 0.0, roll2_ = 0.0;
  CornerValues tyre2_{};
};

// A law on the full car: the four commands [V] for the period after the plant's current state
// (period k from 0).
using FullCarLaw = std::function<void(const FullCarPlant& plant, std::int64_t k, CornerValues*)>;
// Runs the plant from Reset for duration_s, scoring after settle_s; volts_front / volts_rear:
// the mean commands of the front and rear corners.
FullCarRidePoint RunFullCarRide(FullCarPlant* plant, double duration_s, double settle_s,
                                const FullCarLaw& law);
// Each (front, rear) pair of constant voltages run; the points in the pairs' order.
std::vector<FullCarRidePoint> RunFullCarGrid(
    FullCarPlant* plant, double duration_s, double settle_s,
    const std::vector<std::pair<double, double>>& front_rear_volts);

// The index of the point with the lowest metric (the first of equal ones); points not empty.
std::size_t BestFullCarPoint(const std::vector<FullCarRidePoint>& points, FullCarMetric m);
// The lowest metric among points whose worst tyre-load RMS is <= tyre_limit_n.
std::optional<std::size_t> BestFullCarAtHolding(const std::vector<FullCarRidePoint>& points,
                                                double tyre_limit_n, FullCarMetric m);

}  // namespace mrd::hil
