#pragma once
// Three-story shear frame with MR dampers at one or more stories (by default one, between the
// ground and the first floor): the scaled laboratory structure of Dyke, Spencer, Sain & Carlson
// (1996), excited by a ground acceleration. Pure and allocation-free; the structure study
// (docs/structure.md) serves it.
//
//   M x'' + C x' + K x = Gamma (f - f0) - M 1 ag          x: floor displacements rel. ground [m]
//   Gamma: n x m, one column per damper j at story s_j: -1 on floor s_j, +1 on floor s_j - 1
//          (none for the ground): the damper pushes back on the floor above it and forward on
//          the floor below (story 1 alone: Gamma = [-1, 0, 0]^T)
//   damper j: x_d = 100 (x_s - x_{s-1}) [cm] (the story's drift, x_0 = 0), xdot_d likewise
//          [cm/s], f_j = Spencer force [N] (+ resists a positive drift)
//   absolute floor acceleration  xa_i = x_i'' + ag        [m/s^2]
//
// f0 = a damper's force at rest at x_d = 0 (the accumulator term -k1 x0 of the Spencer model),
// a static preload balanced at installation like the quarter car's (quarter_car.hpp); the
// reported force is the dynamic part f - f0.
//
// Coupling: the 6 structural and 3 states (y, z, u) per damper advance together in one RK4
// step, `substeps` per period; ag is linear between the period's ends and each E is held.

#include "mrd/sim/spencer_damper.hpp"

namespace mrd {

struct ShearFrameParams {
  static constexpr int kFloors = 3;
  double mass_kg[kFloors] = {98.3, 98.3, 98.3};
  // Row-major 3x3 stiffness [N/m] and damping [N s/m] of Dyke et al. (1996).
  double stiffness[kFloors * kFloors] = {12.0e5,  -6.84e5, 0.0,     -6.84e5, 13.7e5,
                                         -6.84e5, 0.0,     -6.84e5, 6.84e5};
  double damping[kFloors * kFloors] = {175.0, -50.0, 0.0, -50.0, 100.0, -50.0, 0.0, -50.0, 50.0};
  bool with_damper = true;  // false: the bare frame (no damper force at all)
  // The dampers' stories (1 = ground to floor 1, ..., kFloors), ascending, no story twice;
  // dampers of them used (1..kMaxDampers). Every damper has the same Spencer parameters.
  static constexpr int kMaxDampers = kFloors;
  int dampers = 1;
  int story[kMaxDampers] = {1, 2, 3};

  // True when masses are > 0, every value is finite and the stories are as above; *reason
  // names the field.
  bool IsValid(const char** reason) const;
};

struct ShearFrameSample {
  double x[ShearFrameParams::kFloors] = {};           // floor displacement rel. ground [m]
  double v[ShearFrameParams::kFloors] = {};           // floor velocity rel. ground [m/s]
  double xa[ShearFrameParams::kFloors] = {};          // absolute floor acceleration [m/s^2]
  double force = 0.0;                                 // first damper's force f - f0 [N]
  double forces[ShearFrameParams::kMaxDampers] = {};  // each damper's force f - f0 [N]
};

class ShearFrame {
 public:
  ShearFrame(const ShearFrameParams& frame, const SpencerParams& damper, int substeps = 20);

  // At rest, every damper settled at E [V], ground acceleration ag [m/s^2].
  void Reset(double E, double ag);

  // Advances dt [s] with ag going linearly from ag0 to ag1 [m/s^2] and E [V] held on every
  // damper. Returns the sample at the end of the interval. Real-time safe.
  const ShearFrameSample& Step(double dt, double ag0, double ag1, double E);
  // The same with damper j at E[j] [V] (params().dampers values). Real-time safe.
  const ShearFrameSample& Step(double dt, double ag0, double ag1, const double* E);

  const ShearFrameSample& sample() const { return sample_; }
  const SpencerDamper& damper() const { return damper_; }
  const ShearFrameParams& params() const { return frame_; }

 private:
  static constexpr int kN = ShearFrameParams::kFloors;
  static constexpr int kD = ShearFrameParams::kMaxDampers;
  struct State {
    double x[kN], v[kN];
    SpencerState d[kD];
  };
  // Rates of s at ground acceleration ag and voltages E[j]; accel gets x'' [m/s^2], force[j]
  // f_j - f0 (kD values; unused dampers 0).
  State Rate(const State& s, double ag, const double* E, double* accel, double* force) const;
  int Dampers() const { return frame_.with_damper ? frame_.dampers : 0; }
  void Publish(const double* accel, const double* force, double ag);

  ShearFrameParams frame_;
  SpencerDamper damper_;
  int substeps_;
  double f0_ = 0.0;
  State state_{};
  ShearFrameSample sample_;
};

}  // namespace mrd
