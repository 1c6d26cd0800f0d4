// The full car with a Spencer damper per corner (full_car_plant.hpp).
#include "mrd/hil/plants/full_car_plant.hpp"

#include <algorithm>
#include <cmath>

namespace mrd::hil {
namespace {

TwoTrackRoadParams RoadOf(const FullCarPlantParams& p) {
  TwoTrackRoadParams r = p.road;
  r.wheelbase_m = p.car.wheelbase_m();
  return r;
}

CornerValues Rates(const TwoTrackRoad& road, double speed) {
  CornerValues r;
  for (int i = 0; i < 4; ++i) r[i] = speed * road.slopes()[i];
  return r;
}

}  // namespace

FullCarPlant::FullCarPlant(const FullCarPlantParams& params, double period_s)
    : p_(params),
      period_s_(period_s),
      car_(params.car),
      road_(RoadOf(params), params.speed_m_s * period_s),
      dampers_{SpencerDamper(params.damper, params.damper_substeps),
               SpencerDamper(params.damper, params.damper_substeps),
               SpencerDamper(params.damper, params.damper_substeps),
               SpencerDamper(params.damper, params.damper_substeps)} {
  Reset();
}

void FullCarPlant::Reset() {
  road_.Reset();
  car_.Reset(road_.heights_m(), Rates(road_, p_.speed_m_s));
  for (int i = 0; i < 4; ++i) {
    const double x = car_.Sample().corner[i].damper_x_cm;
    dampers_[i].Reset(x, 0.0);
    f0_[i] = dampers_[i].Force(x, 0.0);
    force_[i] = f0_[i];
    held_[i] = 0.0;
  }
}

const FullCarSample& FullCarPlant::Step(const CornerValues& volts) {
  std::array<double, 4> x0{}, v0{};
  for (int i = 0; i < 4; ++i) {
    x0[i] = car_.Sample().corner[i].damper_x_cm;
    v0[i] = car_.Sample().corner[i].damper_v_cm_s;
  }
  road_.Advance();
  car_.Step(period_s_, road_.heights_m(), Rates(road_, p_.speed_m_s), held_);
  for (int i = 0; i < 4; ++i) {
    const double e = std::isfinite(volts[i]) ? std::clamp(volts[i], 0.0, p_.max_volts) : 0.0;
    const FullCarCorner& c = car_.Sample().corner[i];
    force_[i] = dampers_[i].Step(period_s_, x0[i], v0[i], c.damper_x_cm, c.damper_v_cm_s, e);
    held_[i] = force_[i] - f0_[i];
  }
  return car_.Sample();
}

double FullCarPlant::CornerAccel(int corner) const {
  return car_.PointAccel(p_.car.corner_x_m(corner), p_.car.corner_y_m(corner));
}

}  // namespace mrd::hil
