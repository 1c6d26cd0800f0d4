#pragma once
// Modal skyhook over a four-corner body: heave, pitch and roll rates estimated from the four
// corners' absolute body velocities, skyhook damping per mode, and the modal forces distributed
// back to four damper force demands (each corner's Controller then runs kForceTracking on its
// demand: clamped to +-force_limit and inverted; a demand of the non-passive sign gives E_min).
//
// Axes and signs (as common/sim's full_car.hpp): x forward, y left, z up; pitch theta > 0 nose up,
// roll phi > 0 left side up [rad]. Corners in the order front-left, front-right, rear-left,
// rear-right; corner i sits at x_i = +a (front) or -b (rear), y_i = +t/2 (left) or -t/2 (right),
// t the track of its axle. Its body velocity is
//
//   vb_i = z' + x_i theta' + y_i phi'   (A q, A's rows [1 x_i y_i], q = [z' theta' phi'])
//
// Rates: the least-squares fit over the four corners, q = (A^T A)^-1 A^T vb (exact for a rigid
// body; the one redundant corner averages the sensors' noise). Skyhook on each mode, the force
// and moments on the body w = -[c_heave z', c_pitch theta', c_roll phi'], distributed as the
// least-norm corner forces u = A (A^T A)^-1 w (so sum u_i = w0, sum x_i u_i = w1,
// sum y_i u_i = w2). The damper pulls the body down when its force is positive (control_law.hpp)
// and acts r-fold on the body (r: motion ratio, damper travel / wheel travel), so the demand is
//
//   f_i = -u_i / r   [N, at the damper]
//
// On a car symmetric fore / aft (a = b) and left / right, in pure heave, f_i = c_heave z' / (4 r):
// the per-corner continuous skyhook f = c_sky vb with c_heave = 4 r c_sky (c_sky in N s/m). With
// a != b the heave force acts at the centre of gravity (front corners b / (a + b) of it, no pitch
// moment), where per-corner skyhook also pitches the body.
// Default gains: those of per-corner skyhook 60 N s/cm on the default car (a 1.2, b 1.4, tracks
// 1.5, r 0.7): c_heave = 4 r c, c_pitch = r c (2 a^2 + 2 b^2), c_roll = r c t^2.
//
// Real-time safe: Demands allocates nothing and throws nothing. A non-finite velocity gives
// non-finite demands at every corner it reaches (each Controller's watchdog then goes safe).

#include "mrd/common/result.hpp"
#include "mrd/firmware/real.hpp"

namespace mrd::firmware {

inline constexpr int kModalCorners = 4;  // front-left, front-right, rear-left, rear-right

struct BodyGeometry {
  double cg_to_front_m = 1.2;  // a > 0: centre of gravity to the front axle
  double cg_to_rear_m = 1.4;   // b > 0: centre of gravity to the rear axle
  double track_front_m = 1.5;  // > 0
  double track_rear_m = 1.5;   // > 0
  double motion_ratio = 0.7;   // r in (0, 1]: damper travel / wheel travel
};

struct ModalGains {
  double heave_n_s_per_m = 16800.0;      // c_heave >= 0, on z' [m/s]
  double pitch_n_m_s_per_rad = 28560.0;  // c_pitch >= 0, on theta' [rad/s]
  double roll_n_m_s_per_rad = 9450.0;    // c_roll >= 0, on phi' [rad/s]
};

// Heave [m/s], pitch and roll rates [rad/s] of the body.
struct ModalRates {
  double heave_m_s = 0.0;
  double pitch_rad_s = 0.0;
  double roll_rad_s = 0.0;
};

class ModalSkyhook {
 public:
  // kOk, or kOutOfRange with *reason (static text naming the field; reason may be null) for a
  // value not finite or out of range; a refused configuration changes nothing.
  Error Configure(const BodyGeometry& geometry, const ModalGains& gains,
                  const char** reason = nullptr);
  bool configured() const { return configured_; }

  // The least-squares rates from the four corners' body velocities [cm/s] (up positive).
  ModalRates Rates(const double* body_velocity_cm_s) const noexcept;
  // Four damper force demands [N] (control_law.hpp's sign) from the four corners' body
  // velocities [cm/s]. Before a successful Configure: zero demands.
  void Demands(const double* body_velocity_cm_s, double* demand_n) const noexcept;

 private:
  // fit_[m][i]: row m of (A^T A)^-1 A^T (m: heave, pitch, roll), in per-m units; the
  // distribution is its transpose.
  Real fit_[3][kModalCorners] = {};
  Real gain_[3] = {};
  Real inv_ratio_ = Real(1);
  bool configured_ = false;
};

}  // namespace mrd::firmware
