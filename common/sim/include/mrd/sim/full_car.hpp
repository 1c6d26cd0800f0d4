#pragma once
// Full car, 7 degrees of freedom: body heave z, pitch theta, roll phi and four wheels zu_i, with
// each corner's suspension a spring, an optional linear dashpot and the damper force the caller
// gives (its own damper model, e.g. one SpencerDamper per corner, stepped beside the car).
//
// Axes and signs (deviations from static equilibrium, small angles): x forward, y left, z up;
// theta > 0 nose up, phi > 0 left side up [rad]. Corner i (kFrontLeft, kFrontRight, kRearLeft,
// kRearRight) sits at x_i = +a (front) or -b (rear), y_i = +t/2 (left) or -t/2 (right), t the
// track of its axle. The corner's body point, travel and tyre force:
//
//   zb_i = z + x_i theta + y_i phi                          [m]   (body at the corner)
//   d_i  = zb_i - zu_i                                      [m]   (+ = extension)
//   damper  x_i = 100 r d_i,  xdot_i = 100 r d_i'           [cm, cm/s]   r: motion ratio
//   Fs_i = -ks d_i - cs d_i' - r f_i                        [N]   force on the body, up
//   Ft_i = max(-W_i, kt (zr_i - zu_i) + ct (zr_i' - zu_i')) [N]   W_i: static wheel load (lift-off)
//
//   M z''         = sum Fs_i
//   I_pitch th''  = sum x_i Fs_i
//   I_roll  phi'' = sum y_i Fs_i
//   mu zu_i''     = -Fs_i + Ft_i
//
// f_i [N] is the damper force at the damper (+ resists extension), as in quarter_car.hpp: it acts
// r-fold at the wheel and the damper moves r of the wheel travel. Gravity is balanced by the
// static preload (the states are deviations), so f_i is the force beyond any static one. No
// anti-roll bars. A seat at (xs, ys) accelerates z'' + xs th'' + ys phi''.
//
// Stepping: Step(dt) advances by dt with the damper forces held (zero-order hold: the caller's
// damper model sees the corner's motion at the step ends) and each wheel's road the cubic
// Hermite of (zr, zr') between the step's ends (as the quarter car); `substeps` RK4 steps per
// call. Real-time safe: no allocation, no exceptions.
//
// Default car: typical passenger car values (no single published vehicle), chosen so that each
// corner is close to the quarter car of quarter_car.hpp (static body mass per corner 277..323 kg
// against its 300 kg, same wheel, spring, tyre and motion ratio) and the same damper fits:
//   body M 1200 kg, I_pitch 1800 kg m^2 (radius of gyration 1.22 m), I_roll 450 kg m^2 (0.61 m),
//   a 1.2 m, b 1.4 m (wheelbase 2.6 m, 54 % of the weight on the front axle), tracks 1.50 m,
//   unsprung 40 kg per wheel, ks 20 kN/m, kt 180 kN/m per corner (wheel rates), r 0.7, no
//   suspension or tyre dashpot; the driver's seat at x 0.3 m, y 0.37 m (left-hand drive).
// Undamped modes (full_car_test.cpp's eigen analysis): heave 1.21 Hz, pitch 1.33 Hz, roll 1.51 Hz,
// wheel hop 11.25..11.27 Hz.

#include <array>
#include <cstdint>

namespace mrd {

enum Corner : int { kFrontLeft = 0, kFrontRight = 1, kRearLeft = 2, kRearRight = 3 };
using CornerValues = std::array<double, 4>;  // indexed by Corner

struct FullCarParams {
  double body_mass_kg = 1200.0;           // M, sprung
  double pitch_inertia_kg_m2 = 1800.0;    // about the y axis through the centre of gravity
  double roll_inertia_kg_m2 = 450.0;      // about the x axis through the centre of gravity
  double cg_to_front_m = 1.2;             // a, > 0
  double cg_to_rear_m = 1.4;              // b, > 0
  double track_front_m = 1.5;             // > 0
  double track_rear_m = 1.5;              // > 0
  double unsprung_front_kg = 40.0;        // per wheel
  double unsprung_rear_kg = 40.0;         // per wheel
  double spring_front_n_per_m = 20000.0;  // ks per corner (wheel rate), > 0
  double spring_rear_n_per_m = 20000.0;   //
  double damping_front_n_s_per_m = 0.0;   // cs per corner at the wheel, >= 0 (passive, inside)
  double damping_rear_n_s_per_m = 0.0;    //
  double tyre_n_per_m = 180000.0;         // kt, > 0
  double tyre_damping_n_s_per_m = 0.0;    // ct, >= 0
  double motion_ratio = 0.7;              // r, damper travel / wheel travel, (0, 1]
  double seat_x_m = 0.3;                  // seat point ahead of the centre of gravity
  double seat_y_m = 0.37;                 // seat point left of the centre of gravity
  int substeps = 10;                      // RK4 steps per Step, 1..10000

  // True when every value is finite and in range; on failure *reason names the field.
  bool IsValid(const char** reason) const;
  double wheelbase_m() const { return cg_to_front_m + cg_to_rear_m; }
  double corner_x_m(int corner) const;  // +a or -b
  double corner_y_m(int corner) const;  // +t/2 or -t/2
};

// One corner at an instant.
struct FullCarCorner {
  double travel_m = 0.0;            // d = zb - zu (+ extension)
  double travel_rate_m_s = 0.0;     // d'
  double damper_x_cm = 0.0;         // 100 r d: what the damper sees [cm]
  double damper_v_cm_s = 0.0;       // 100 r d' [cm/s]
  double body_velocity_m_s = 0.0;   // zb'
  double wheel_velocity_m_s = 0.0;  // zu'
  double tyre_deflection_m = 0.0;   // zr - zu (+ compression beyond static)
  double tyre_load_n = 0.0;         // Ft, load variation (-W: wheel off the ground)
  double damper_force_n = 0.0;      // f held over the last step [N]
  bool airborne = false;            // Ft at its floor
};

struct FullCarSample {
  double t_s = 0.0;
  std::array<FullCarCorner, 4> corner;
  double heave_m = 0.0, heave_velocity_m_s = 0.0, heave_accel = 0.0;  // z, z', z'' [m/s^2]
  double pitch_rad = 0.0, pitch_rate = 0.0, pitch_accel = 0.0;        // theta [rad, /s, /s^2]
  double roll_rad = 0.0, roll_rate = 0.0, roll_accel = 0.0;           // phi [rad, /s, /s^2]
  double seat_accel = 0.0;  // vertical at the params' seat point [m/s^2]
};

class FullCar {
 public:
  // Invalid parameters are the caller's to check (IsValid); substeps < 1 is taken as 1.
  explicit FullCar(const FullCarParams& params);

  struct State {
    double z, vz, th, wth, ph, wph;  // body [m, m/s, rad, rad/s, rad, rad/s]
    CornerValues zu, vu;             // wheels [m, m/s]
  };

  // At rest in static equilibrium on road heights zr [m] (a linear solve: the wheels and the
  // body settle on an uneven road), road rates zr' [m/s] remembered for the first step's
  // Hermite; t = 0, damper forces 0.
  void Reset(const CornerValues& road_m, const CornerValues& road_rate_m_s);
  // Any state (tests, initial conditions), road as Reset; the sample is recomputed.
  void SetState(const State& s, const CornerValues& road_m, const CornerValues& road_rate_m_s);

  // Advances dt > 0 [s]: road heights and rates are those at the end of the step; damper forces
  // [N] (at the damper, + resists extension; non-finite: 0) are held over it. Returns the
  // sample at the end. Real-time safe.
  const FullCarSample& Step(double dt, const CornerValues& road_m,
                            const CornerValues& road_rate_m_s, const CornerValues& damper_n);

  const FullCarSample& Sample() const { return sample_; }
  const State& state() const { return state_; }
  const FullCarParams& params() const { return p_; }
  // Vertical acceleration [m/s^2] of the body point at (x, y) [m] from the centre of gravity.
  double PointAccel(double x_m, double y_m) const;
  double static_wheel_load_n(int corner) const { return weight_[corner]; }

 private:
  struct Rates {
    State d;  // time derivative of the state
    CornerValues fs, ft;
  };
  Rates Derivative(const State& s, const CornerValues& zr, const CornerValues& vr) const;
  void UpdateSample();

  FullCarParams p_;
  CornerValues x_{}, y_{}, ks_{}, cs_{}, mu_{}, weight_{};
  State state_{};
  CornerValues zr_{}, vr_{}, f_{};
  double t_s_ = 0.0;
  FullCarSample sample_;
};

}  // namespace mrd
