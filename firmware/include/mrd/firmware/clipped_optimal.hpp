#pragma once
// Clipped-optimal control of MR dampers (Dyke, Spencer, Sain & Carlson 1996): a discrete
// Kalman observer estimates the structure's state from measured absolute floor accelerations
// and the measured damper forces; a linear optimal (H2/LQG) gain gives each damper's desired
// force f_c,j; each damper's voltage is switched by the clipped rule on its own forces
//
//   v_j = V_max  when (f_c,j - f_j) f_j > 0   (the damper force must grow towards f_c,j)
//   v_j = V_min  otherwise                    (H is the Heaviside step; V_min = 0 in the paper)
//
// Observer (predictor form, one period T), m = dampers force inputs (1..kMaxDampers):
//   f_c      = -K xh                            K: m x kStates
//   xh+      = Ad xh + Bd f + L (y - Cy xh - Dy f)   Bd: kStates x m, Dy: kOutputs x m
// y: kOutputs absolute accelerations [m/s^2], f: the m measured forces [N], xh: kStates
// estimate (floor displacements [m] then velocities [m/s] relative to the ground for the
// 3-story frame). One damper (m = 1) is the paper's design and the arrays' first elements.
// The gains come from an off-line design (mrd-structure design); sizes are fixed at compile
// time. Real-time safe: no allocation, no exceptions, no blocking.

#include "mrd/firmware/real.hpp"

namespace mrd::firmware {

struct ClippedOptimalGains {
  static constexpr int kStates = 6;
  static constexpr int kOutputs = 3;
  static constexpr int kMaxDampers = 3;
  int dampers = 1;  // m: force inputs, 1..kMaxDampers; the arrays' used parts below
  double ad[kStates * kStates] = {};       // row-major discrete state matrix
  double bd[kStates * kMaxDampers] = {};   // row-major kStates x m force input [per N]
  double cy[kOutputs * kStates] = {};      // accelerations from the state
  double dy[kOutputs * kMaxDampers] = {};  // row-major kOutputs x m [m/s^2 per N]
  double l[kStates * kOutputs] = {};       // row-major observer gain
  double k[kMaxDampers * kStates] = {};    // row-major m x kStates: f_c = -k xh [N]
  double v_max = 2.25;                     // [V]
  double v_min = 0.0;                      // [V]
  // True when every value is finite, 1 <= dampers <= kMaxDampers and v_min <= v_max;
  // *reason names the field.
  bool IsValid(const char** reason) const;
};

// The clipped rule alone: v_max when (fc - f) f > 0, else v_min. Real-time safe.
Real ClippedRule(Real fc, Real f, Real v_max, Real v_min);

class ClippedOptimal {
 public:
  static constexpr int kStates = ClippedOptimalGains::kStates;
  static constexpr int kOutputs = ClippedOptimalGains::kOutputs;
  static constexpr int kMaxDampers = ClippedOptimalGains::kMaxDampers;

  // gains.dampers out of 1..kMaxDampers is taken as 1 (IsValid refuses it first).
  void Configure(const ClippedOptimalGains& gains);
  void Reset();  // estimate to zero (structure at rest)

  // One period: accel[kOutputs] measured absolute accelerations [m/s^2], force[dampers()] the
  // measured damper forces [N]; volts[dampers()] gets each damper's voltage [V] for the next
  // period. Real-time safe.
  void Update(const Real* accel, const Real* force, Real* volts);
  // The one-damper form (dampers() == 1; with more, the others' forces are taken as 0 and
  // the first damper's voltage returned). Real-time safe.
  Real Update(const Real* accel, Real force);

  int dampers() const { return m_; }
  Real desired_force(int j = 0) const { return fc_[j]; }  // f_c,j of the last Update [N]
  const Real* estimate() const { return xh_; }            // state estimate after the last Update

 private:
  int m_ = 1;
  Real ad_[kStates * kStates] = {};
  Real bd_[kStates * kMaxDampers] = {};
  Real cy_[kOutputs * kStates] = {};
  Real dy_[kOutputs * kMaxDampers] = {};
  Real l_[kStates * kOutputs] = {};
  Real k_[kMaxDampers * kStates] = {};
  Real v_max_ = Real(2.25);
  Real v_min_ = Real(0);
  Real xh_[kStates] = {};
  Real fc_[kMaxDampers] = {};
};

}  // namespace mrd::firmware
