#pragma once
// The reference plant as the firmware's sensors and driver see it: the Spencer damper
// (spencer_damper.hpp) driven by a periodic excitation, stepped one control period at a time
// with the applied voltage held (zero-order hold). Used by the firmware's dry run and by the
// HIL harness, so both serve the same plant.
//
// Excitation at plant time t [s]:
//   x(t)  = A sin(2 pi f t)                                  relative displacement [cm]
//   v(t)  = 2 pi f A cos(2 pi f t)                           relative velocity [cm/s]
//   d(t)  = D (0.65 + 0.35 sin(2 pi f_d t)) tanh(v / 2 cm/s) force demand [N] (dissipative,
//           as a semi-active damper can deliver)
//   vb(t) = B sin(2 pi f_b t + phi)                          body velocity [cm/s]
//   ab(t) = 2 pi f_b B cos(2 pi f_b t + phi)                 body acceleration [cm/s^2]
//   vw(t) = vb(t) - v(t)                                     wheel velocity [cm/s]
//   xa_i(t) = 0.01 ab(t) (1, 1.5, 2)_i                        floor accelerations [m/s^2]
//   (stand-in)
// Pure and allocation-free; Step is real-time safe.

#include <cstdint>

#include "mrd/sim/spencer_damper.hpp"

namespace mrd {

struct PlantExcitation {
  double amplitude_cm = 1.0;           // A
  double frequency_hz = 2.0;           // f
  double demand_amplitude_n = 1200.0;  // D
  double demand_frequency_hz = 0.5;    // f_d
  double body_amplitude = 8.0;         // B [cm/s]
  double body_frequency_hz = 1.3;      // f_b
  double body_phase_rad = 0.7;         // phi
  int substeps = 20;                   // RK4 steps per period (>= 1)
};

// What the plant's sensors read at one instant.
struct PlantSample {
  double t_s = 0.0;                // plant time [s]
  double x = 0.0;                  // [cm]
  double v = 0.0;                  // [cm/s]
  double demand = 0.0;             // [N]
  double body_velocity = 0.0;      // [cm/s]
  double force = 0.0;              // damper force [N]
  double body_acceleration = 0.0;  // absolute body acceleration [cm/s^2]
  double wheel_velocity = 0.0;     // absolute wheel (unsprung) velocity [cm/s]
  // The plant has a body and a wheel (the quarter car): the harness serves the two above on
  // the buses. False: the dry-run values stand in (the firmware's simulated damper only).
  bool has_chassis = false;
  // Absolute floor accelerations of a structure [m/s^2] (the structure plant; the dry run's
  // stand-in: the body acceleration in m/s^2 times 1, 1.5, 2).
  double floor_acceleration[3] = {};
  // The plant is the three-story structure: the harness serves the floor accelerations.
  bool has_structure = false;
};

class DamperPlant {
 public:
  // period_s > 0: one Step advances this much.
  DamperPlant(const SpencerParams& params, const PlantExcitation& excitation, double period_s);

  // Back to t = 0 at rest, voltage filter settled at 0 V.
  void Reset();
  // Advances one period with volts [V] held; returns the sample at the end. Real-time safe.
  PlantSample Step(double volts);
  // Sample at the current plant time (no advance).
  PlantSample Sample() const;

  double period_s() const { return period_s_; }
  std::uint64_t steps() const { return steps_; }
  const PlantExcitation& excitation() const { return excitation_; }

 private:
  double X(double t) const;
  double V(double t) const;

  SpencerDamper damper_;
  PlantExcitation excitation_;
  double period_s_;
  std::uint64_t steps_ = 0;
  double force_ = 0.0;
};

}  // namespace mrd
