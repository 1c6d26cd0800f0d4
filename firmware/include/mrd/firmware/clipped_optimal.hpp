#pragma once
// Clipped-optimal control of an MR damper (Dyke, Spencer, Sain & Carlson 1996): a discrete
// Kalman observer estimates the structure's state from measured absolute floor accelerations
// and the measured damper force; a linear optimal (H2/LQG) gain gives the desired force f_c;
// the damper voltage is switched by the clipped rule
//
//   v = V_max  when (f_c - f) f > 0   (the damper force must grow towards f_c)
//   v = V_min  otherwise              (H is the Heaviside step; V_min = 0 in the paper)
//
// Observer (predictor form, one period T):
//   f_c      = -K xh
//   xh+      = Ad xh + Bd f + L (y - Cy xh - Dy f)
// y: kOutputs absolute accelerations [m/s^2], f: measured force [N], xh: kStates estimate
// (floor displacements [m] then velocities [m/s] relative to the ground for the 3-story frame).
// The gains come from an off-line design (mrd-structure design); sizes are fixed at compile
// time. Real-time safe: no allocation, no exceptions, no blocking.

#include "mrd/firmware/real.hpp"

namespace mrd::firmware {

struct ClippedOptimalGains {
  static constexpr int kStates = 6;
  static constexpr int kOutputs = 3;
  double ad[kStates * kStates] = {};   // row-major discrete state matrix
  double bd[kStates] = {};             // discrete force input [per N]
  double cy[kOutputs * kStates] = {};  // accelerations from the state
  double dy[kOutputs] = {};            // accelerations from the force [m/s^2 per N]
  double l[kStates * kOutputs] = {};   // row-major observer gain
  double k[kStates] = {};              // optimal gain: f_c = -k . xh [N]
  double v_max = 2.25;                 // [V]
  double v_min = 0.0;                  // [V]
  // True when every value is finite and v_min <= v_max; *reason names the field.
  bool IsValid(const char** reason) const;
};

// The clipped rule alone: v_max when (fc - f) f > 0, else v_min. Real-time safe.
Real ClippedRule(Real fc, Real f, Real v_max, Real v_min);

class ClippedOptimal {
 public:
  static constexpr int kStates = ClippedOptimalGains::kStates;
  static constexpr int kOutputs = ClippedOptimalGains::kOutputs;

  void Configure(const ClippedOptimalGains& gains);
  void Reset();  // estimate to zero (structure at rest)

  // One period: accel[kOutputs] measured absolute accelerations [m/s^2], force the measured
  // damper force [N]. Returns the voltage [V] to apply for the next period. Real-time safe.
  Real Update(const Real* accel, Real force);

  Real desired_force() const { return fc_; }    // f_c of the last Update [N]
  const Real* estimate() const { return xh_; }  // state estimate after the last Update

 private:
  Real ad_[kStates * kStates] = {};
  Real bd_[kStates] = {};
  Real cy_[kOutputs * kStates] = {};
  Real dy_[kOutputs] = {};
  Real l_[kStates * kOutputs] = {};
  Real k_[kStates] = {};
  Real v_max_ = Real(2.25);
  Real v_min_ = Real(0);
  Real xh_[kStates] = {};
  Real fc_ = Real(0);
};

}  // namespace mrd::firmware
