#pragma once
// A quarter car's ride figures and the arithmetic of the passive comparison
// (study/passive_baseline.hpp runs the grid of a scenario): the ride metrics, a scorer that
// takes them sample by sample (ISO 2631-1 Wk weighting too), one run of a quarter-car plant
// under a law, the constant-voltage grid, the best passive setting per metric and the
// improvement over it, and the body acceleration's PSD. Not real-time.

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mrd/common/iso2631_weighting.hpp"
#include "mrd/common/welch_psd.hpp"
#include "mrd/sim/quarter_car.hpp"

namespace mrd::hil {

enum class RideMetric : std::uint8_t { kBodyAccel = 0, kBodyAccelWk, kTyreLoad, kTravel };
inline constexpr std::size_t kNumRideMetrics = 4;
inline constexpr std::array<RideMetric, kNumRideMetrics> kRideMetrics = {
    RideMetric::kBodyAccel, RideMetric::kBodyAccelWk, RideMetric::kTyreLoad, RideMetric::kTravel};
// JSON/CSV key ("body_accel_rms", "body_accel_wk_rms", "tyre_load_rms_n", "travel_rms_cm").
const char* RideMetricKey(RideMetric m);
// Words with the unit ("body acceleration RMS [m/s^2]", ...).
const char* RideMetricTitle(RideMetric m);

// One run's ride figures (after the settle time).
struct RidePoint {
  double volts = 0.0;              // the held voltage (passive) or the mean command (a law) [V]
  double body_accel_rms = 0.0;     // [m/s^2]
  double body_accel_wk_rms = 0.0;  // ISO 2631-1 Wk weighted [m/s^2]
  double tyre_load_rms_n = 0.0;    // [N]
  double travel_rms_cm = 0.0;      // [cm]
  std::uint64_t samples = 0;
  std::uint64_t lift_off = 0;  // samples with the wheel off the ground
};
double MetricOf(const RidePoint& p, RideMetric m);

// Scores a run sample by sample: RideMetrics plus the Wk-weighted body acceleration.
class RideScorer {
 public:
  RideScorer(double settle_s, double fs_hz);
  void Add(const QuarterCarSample& s);
  // Only the body acceleration (a trace): the Wk filter and its RMS after settle_s.
  void AddWk(double t_s, double body_accel);
  RidePoint Point() const;
  double wk_rms() const;

 private:
  double settle_s_;
  RideMetrics ride_;
  WkFilter wk_;
  double wk2_ = 0.0;
  std::uint64_t wk_n_ = 0;
};

// The law of a run: the command [V] for the period after `sample` (period k from 0).
using RideLaw = std::function<double(const PlantSample& sample, std::int64_t k)>;
// Runs the plant from Reset for duration_s, the law's command held over each period; scores
// after settle_s. accel (optional): every period's body acceleration after settle_s [m/s^2].
// mean command goes into RidePoint::volts.
RidePoint RunRide(QuarterCarPlant* plant, double duration_s, double settle_s, const RideLaw& law,
                  std::vector<double>* accel = nullptr);

// lo, lo + step, ... <= hi (+ hi itself when the step does not land on it; within 1e-9 V it
// does). false with *error: step not > 0, lo > hi, non-finite, or more than 100000 points.
bool GridVoltages(double lo, double hi, double step, std::vector<double>* out, std::string* error);

struct PassiveBest {
  std::size_t index = 0;  // into the grid's points
  double volts = 0.0;
  double value = 0.0;
};
// The point with the lowest metric (the first of equal ones). points must not be empty.
PassiveBest BestOf(const std::vector<RidePoint>& points, RideMetric m);
// The lowest body-acceleration RMS (or another metric) among points with
// tyre_load_rms_n <= tyre_limit_n.
std::optional<PassiveBest> BestComfortAtRoadHolding(const std::vector<RidePoint>& points,
                                                    double tyre_limit_n,
                                                    RideMetric m = RideMetric::kBodyAccel);
// 100 (best - value) / best; 0 when best is 0.
double ImprovementPercent(double best, double value);

struct PassiveComparison {
  std::array<PassiveBest, kNumRideMetrics> best{};       // per metric, over the grid
  std::array<double, kNumRideMetrics> improvement{};     // controlled vs best, [%]
  std::optional<PassiveBest> comfort_at_holding;         // BestComfortAtRoadHolding
  std::optional<double> comfort_at_holding_improvement;  // body acc, [%]
  std::optional<PassiveBest> wk_at_holding;              // the same for the Wk-weighted RMS
  std::optional<double> wk_at_holding_improvement;       // [%]
};
PassiveComparison Compare(const std::vector<RidePoint>& grid, const RidePoint& controlled);

// Welch PSD of a body acceleration (segments of up to 4096 samples, at least 4 of them when
// the run is shorter); empty when fewer than 32 samples.
Psd BodyAccelPsd(const std::vector<double>& accel, double fs_hz);

// What `mrd-hil run` reports for a quarter car.
struct PassiveBaseline {
  double step_v = 0.05;
  std::vector<RidePoint> grid;
  RidePoint controlled;
  PassiveComparison comparison;
  Psd psd_off, psd_best, psd_controlled;  // body acc: 0 V, best passive (body acc), the run
};
}  // namespace mrd::hil
