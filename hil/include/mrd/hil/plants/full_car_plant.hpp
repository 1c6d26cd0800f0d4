#pragma once
// The full car of the harness study: FullCar (full_car.hpp, 7 DOF) with the scenario's damper
// (the Spencer model of its preset or params file, the quarter car's damper) at each corner, on
// two ISO 8608 tracks (two_track_road.hpp), at 1 kHz.
//
// Coupling per period: the car advances with the four damper forces held (the forces at the
// period's start), then each damper advances over the period on its corner's motion (damper
// x, xdot at both ends) with its voltage held; its force at the end is held over the next
// period. This one-period lag of the damper force is the difference from the quarter car, whose
// damper is integrated with the car in one RK4 step. Each damper's force at rest at its start
// position is balanced by the static preload (as quarter_car.hpp's f0). Deterministic;
// Step allocates nothing.

#include <array>
#include <cstdint>

#include "mrd/sim/full_car.hpp"
#include "mrd/sim/spencer_damper.hpp"
#include "mrd/sim/two_track_road.hpp"

namespace mrd::hil {

struct FullCarPlantParams {
  SpencerParams damper;      // each corner's
  int damper_substeps = 20;  // RK4 steps of each damper per period
  FullCarParams car;
  TwoTrackRoadParams road;  // road.wheelbase_m is taken from the car
  double speed_m_s = 20.0;  // >= 0
  double max_volts = 2.25;  // commands clamped to [0, max_volts] [V]
};

class FullCarPlant {
 public:
  FullCarPlant(const FullCarPlantParams& params, double period_s);
  // t = 0 at rest on the road, dampers at rest, their voltage filters at 0 V.
  void Reset();
  // One period with each corner's voltage held (non-finite: 0 V; clamped to [0, max_volts]).
  const FullCarSample& Step(const CornerValues& volts);
  const FullCarSample& Sample() const { return car_.Sample(); }
  // Each damper's force at the end of the last period [N] (the Spencer force, f0 included).
  const CornerValues& damper_force_n() const { return force_; }
  // Corner body acceleration [m/s^2] at the end of the last period.
  double CornerAccel(int corner) const;
  double period_s() const { return period_s_; }
  const FullCarPlantParams& params() const { return p_; }

 private:
  FullCarPlantParams p_;
  double period_s_;
  FullCar car_;
  TwoTrackRoad road_;
  std::array<SpencerDamper, 4> dampers_;
  CornerValues f0_{}, force_{}, held_{};
};

}  // namespace mrd::hil
