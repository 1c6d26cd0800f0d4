// Two-track road (two_track_road.hpp).
#include "mrd/sim/two_track_road.hpp"

#include <cmath>

namespace mrd {
namespace {

// The seed of realisation k (0 shared, 1 left, 2 right): splitmix64 of seed + k (k = 0 keeps the
// seed itself, so the shared component is the single-track road of the same seed).
RoadParams Realisation(const RoadParams& road, std::uint64_t k) {
  RoadParams r = road;
  if (k == 0) return r;
  std::uint64_t z = road.seed + k * 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  r.seed = z ^ (z >> 31);
  return r;
}

}  // namespace

bool TwoTrackRoadParams::IsValid(const char** reason) const {
  if (!road.IsValid(reason)) return false;
  const char* bad = nullptr;
  if (!std::isfinite(correlation) || correlation < 0.0 || correlation > 1.0) {
    bad = "correlation";
  } else if (!std::isfinite(wheelbase_m) || !(wheelbase_m > 0.0)) {
    bad = "wheelbase_m";
  }
  if (bad != nullptr && reason != nullptr) *reason = bad;
  return bad == nullptr;
}

TwoTrackRoad::TwoTrackRoad(const TwoTrackRoadParams& params, double ds_m)
    : params_(params),
      ws_(std::sqrt(std::fmin(std::fmax(params.correlation, 0.0), 1.0))),
      wi_(std::sqrt(1.0 - ws_ * ws_)),
      shared_(Realisation(params.road, 0)),
      left_(Realisation(params.road, 1)),
      right_(Realisation(params.road, 2)),
      shared_front_(shared_, ds_m),
      left_front_(left_, ds_m),
      right_front_(right_, ds_m),
      shared_rear_(shared_, ds_m),
      left_rear_(left_, ds_m),
      right_rear_(right_, ds_m) {
  Reset();
}

void TwoTrackRoad::Reset() {
  const double lag = params_.wheelbase_m;
  shared_front_.Reset(0.0);
  left_front_.Reset(0.0);
  right_front_.Reset(0.0);
  shared_rear_.Reset(-lag);
  left_rear_.Reset(-lag);
  right_rear_.Reset(-lag);
  Collect();
}

void TwoTrackRoad::Advance() {
  for (RoadTrack* t :
       {&shared_front_, &left_front_, &right_front_, &shared_rear_, &left_rear_, &right_rear_}) {
    t->Advance();
  }
  Collect();
}

void TwoTrackRoad::Collect() {
  const auto mix = [&](const RoadTrack& s, const RoadTrack& i, int corner) {
    height_[corner] = ws_ * s.height_m() + wi_ * i.height_m();
    slope_[corner] = ws_ * s.slope() + wi_ * i.slope();
  };
  mix(shared_front_, left_front_, kFrontLeft);
  mix(shared_front_, right_front_, kFrontRight);
  mix(shared_rear_, left_rear_, kRearLeft);
  mix(shared_rear_, right_rear_, kRearRight);
}

double TwoTrackRoad::TrackHeight(bool left, double s_m) const {
  return ws_ * shared_.Height(s_m) + wi_ * (left ? left_ : right_).Height(s_m);
}

}  // namespace mrd
