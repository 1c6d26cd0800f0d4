#pragma once
// Quarter car on an ISO 8608 road with the Spencer MR damper between body and wheel: the
// skyhook plant of the HIL harness, shaped like DamperPlant (damper_plant.hpp) so the harness
// can serve either: Step(volts) per control period, PlantSample out.
//
// States (deviations from static equilibrium, up positive): body zs, vs; wheel zu, vu [m, m/s];
// damper (y, z, u) of spencer_damper.hpp. Road zr(t) = h(speed * t) [m].
//
//   travel  d  = zs - zu                         [m]   (+ = extension)
//   damper  x  = 100 r d,  xdot = 100 r (vs - vu)  [cm, cm/s]   r: motion ratio
//   f          = Spencer force at (x, xdot)      [N]   (+ resists extension)
//   tyre    Ft = max(-W, kt (zr - zu))            [N]   W = (ms + mu) g: lift-off at Ft = -W
//   ms zs'' = -ks d - r (f - f0)
//   mu zu'' =  ks d + r (f - f0) + Ft
//
// f0 = damper force at rest at x = 0 (the Spencer accumulator term -k1 x0), balanced by the
// static preload like gravity. ks is the wheel rate; the damper works through the motion ratio
// r (damper travel per wheel travel), so it adds r^2 of its damping at the wheel.
//
// Coupling: body, wheel and damper (7 states) advance together in one RK4 step, `substeps` per
// period; the road is the cubic Hermite of (zr, zr') between the period's ends (a RoadTrack
// advanced once per period). The voltage is held over the period and enters through the damper's
// own field filter u' = -eta (u - E). Reset starts at rest on the road height at t = 0, so a run
// should discard a settling time (~2 s) before scoring.

#include <cstdint>

#include "mrd/sim/damper_plant.hpp"
#include "mrd/sim/iso8608_road.hpp"
#include "mrd/sim/spencer_damper.hpp"

namespace mrd {

// Defaults: a light passenger car corner (docs in quarter_car.cpp's header comment).
struct QuarterCarParams {
  double sprung_mass_kg = 300.0;    // ms
  double unsprung_mass_kg = 40.0;   // mu
  double spring_n_per_m = 20000.0;  // ks, wheel rate
  double tyre_n_per_m = 180000.0;   // kt
  double motion_ratio = 0.7;        // r, damper travel / wheel travel, (0, 1]
  double speed_m_s = 20.0;          // vehicle speed, >= 0
  double max_volts = 5.0;           // commands are applied clamped to [0, max_volts] [V]
  int substeps = 10;                // RK4 steps per period, 1..10000

  bool IsValid(const char** reason) const;
};

// The quarter car's own outputs at one instant.
struct QuarterCarSample {
  PlantSample plant;         // x, v: damper [cm, cm/s]; body_velocity [cm/s]; force:
                             // damper [N]; demand: 0 (the law makes its own);
                             // body_acceleration zs'' [cm/s^2]; wheel_velocity zu' [cm/s]
  double body_accel = 0.0;   // zs'' [m/s^2]
  double travel_cm = 0.0;    // suspension (wheel) travel zs - zu [cm]
  double tyre_load_n = 0.0;  // tyre load variation Ft [N] (-W: wheel off the ground)
  double road_m = 0.0;       // road height under the tyre [m]
  double distance_m = 0.0;   // travelled [m]
  bool airborne = false;     // tyre force at its floor (lift-off)
};

class QuarterCarPlant {
 public:
  // period_s > 0. Invalid car parameters are the caller's to check (IsValid).
  QuarterCarPlant(const SpencerParams& damper, const QuarterCarParams& car, const RoadParams& road,
                  double period_s);

  // Back to t = 0 at rest on the road, voltage filter settled at 0 V.
  void Reset();
  // Advances one period with volts [V] held (non-finite: 0 V; clamped to [0, max_volts]);
  // returns the sample at the end. Real-time safe (no allocation).
  PlantSample Step(double volts);
  PlantSample Sample() const { return detail_.plant; }
  const QuarterCarSample& Detail() const { return detail_; }

  double period_s() const { return period_s_; }
  std::uint64_t steps() const { return steps_; }
  double static_tyre_load_n() const { return weight_n_; }
  const QuarterCarParams& car() const { return car_; }
  const Iso8608Road& road() const { return road_; }

  struct State {
    double zs, vs, zu, vu;  // [m, m/s]
    SpencerState d;
  };
  const State& state() const { return state_; }

 private:
  struct Forces {
    double damper;  // f [N]
    double susp;    // force on the body [N]
    double tyre;    // Ft [N]
  };
  Forces ForcesAt(const State& s, double zr) const;
  State Rates(const State& s, double zr, double E) const;
  void UpdateDetail(double zr);

  SpencerDamper damper_;
  QuarterCarParams car_;
  Iso8608Road road_;
  RoadTrack track_;  // road_ at speed * period steps
  double period_s_;
  double weight_n_;
  double f0_ = 0.0;
  std::uint64_t steps_ = 0;
  State state_{};
  double zr_ = 0.0, vr_ = 0.0;  // road at the current time [m, m/s]
  QuarterCarSample detail_;
};

// RMS of the quarter car's ride figures over the samples added.
class RideMetrics {
 public:
  void Add(const QuarterCarSample& s);
  std::uint64_t count() const { return n_; }
  double body_accel_rms() const;                         // [m/s^2]
  double travel_rms_cm() const;                          // [cm]
  double tyre_load_rms_n() const;                        // [N]
  double max_travel_cm() const { return max_travel_; }   // |zs - zu| peak [cm]
  double max_force_n() const { return max_force_; }      // |damper force| peak [N]
  double damper_velocity_rms() const;                    // damper xdot RMS [cm/s]
  double max_damper_velocity() const { return max_v_; }  // |damper xdot| peak [cm/s]
  std::uint64_t lift_off() const { return lift_off_; }   // samples with the wheel airborne

 private:
  std::uint64_t n_ = 0;
  double acc2_ = 0.0, travel2_ = 0.0, tyre2_ = 0.0, v2_ = 0.0;
  double max_travel_ = 0.0, max_force_ = 0.0, max_v_ = 0.0;
  std::uint64_t lift_off_ = 0;
};

// Resets the plant and runs it duration_s at a constant voltage, scoring after settle_s.
RideMetrics RunConstantVoltage(QuarterCarPlant* plant, double volts, double duration_s,
                               double settle_s);

}  // namespace mrd
