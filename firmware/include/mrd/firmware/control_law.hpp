#pragma once
// Control laws: what the damper should do this period, as a force to invert or a voltage.
//
// Sign convention (as the model and the Spencer damper): damper force f [N] is positive for
// positive relative velocity v [cm/s] (extension), so a passive damper has f v >= 0.
//
//   kForceTracking:      f_d = demand (from the bus), clamped to +-force_limit
//   kConstantVoltage:    E = constant_voltage (passive-off 0 V, passive-on E_max)
//   kSkyhookOnOff:       E = E_max when vb v > 0, else E_min           (two-state skyhook)
//   kSkyhookContinuous:  f_d = c_sky vb when vb v > 0, else 0           (then inverted, so
//                        the command saturates to the least force the damper can give)
//   kOpenLoop:           E = demand / 1000: the demand input carries a voltage command in mV
//                        (the CAN demand signal's 0.5 count resolution is 0.5 mV then),
//                        clamped to [E_min, E_max] like every voltage; no model, no inversion
//                        (replaying a measured run's E: the harness's replay scenarios)
//   kGroundhook:         f_d = -c_gnd vw when -vw v > 0, else 0        (inverted like skyhook)
//   kGroundhookOnOff:    E = E_max when -vw v > 0, else E_min
//   kHybrid:             f_d = c_hyb (alpha s_sky + (1 - alpha) s_gnd)   (Ahmadian's hybrid;
//                        s_sky = vb when vb v > 0 else 0, s_gnd = -vw when -vw v > 0 else 0;
//                        inverted like skyhook)
//   kAdd:                E = E_max when ab v > 0, else E_min  (acceleration-driven damper,
//                        Savaresi, Silani & Bittanti 2005)
//   kSkyhookAdd:         E = E_max when  (ab^2 - a^2 vb^2 <= 0 and vb v > 0)
//                                     or (ab^2 - a^2 vb^2 >  0 and ab v > 0), else E_min
//                        (mixed SH-ADD, Savaresi & Spelta 2007, ASME J. Dyn. Sys. Meas.
//                        Control 129(4): skyhook below the crossover frequency a, ADD above)
//   kClippedOptimal:     Dyke et al. 1996 (clipped_optimal.hpp), run by the Controller's
//                        ClippedOptimal object on the floor accelerations and the measured
//                        force: E = the clipped rule's v_max / v_min (clamped to [E_min,
//                        E_max]; clipped_command kClipped), or the inverse of the model at the
//                        desired force f_c (kInverse)
//
// vb: absolute body velocity [cm/s]; vw: absolute wheel (unsprung) velocity [cm/s]; ab: body
// acceleration [cm/s^2]; all up positive, v = body minus wheel (times the motion ratio), so the
// damper pulls the body down and the wheel up when f > 0. Skyhook wants -c vb on the body,
// groundhook -c vw on the wheel: the damper gives either only when its sign is f's passive one.
// c_sky, c_gnd, c_hyb: gains [N s/cm]; alpha: hybrid blend in [0, 1] (1 = skyhook, 0 =
// groundhook); a: SH-ADD crossover [rad/s] (the units of ab / vb).
// Per-sample arithmetic in Real (real.hpp); the configuration is double.

#include <cstdint>

#include "mrd/firmware/real.hpp"

namespace mrd::firmware {

enum class ControlMode : std::uint8_t {
  kForceTracking = 0,
  kConstantVoltage,
  kSkyhookOnOff,
  kSkyhookContinuous,
  kOpenLoop,
  kGroundhook,
  kGroundhookOnOff,
  kHybrid,
  kAdd,
  kSkyhookAdd,
  // Clipped-optimal (clipped_optimal.hpp): a stateful observer-based law run by the
  // Controller's own ClippedOptimal object with the gains of ControllerConfig; the stateless
  // ControlLaw holds E_min for it.
  kClippedOptimal,
};

// What the clipped-optimal law commands: the clipped rule's voltage (Dyke et al.), or the
// model's inverse at the desired force f_c.
enum class ClippedCommand : std::uint8_t { kClipped = 0, kInverse };

struct ControlLawConfig {
  ControlMode mode = ControlMode::kForceTracking;
  double constant_voltage = 0.0;   // [V], kConstantVoltage
  double skyhook_gain = 100.0;     // [N s/cm], kSkyhookContinuous
  double force_limit = 5000.0;     // [N], |force demand| limit, > 0
  double groundhook_gain = 100.0;  // [N s/cm], kGroundhook
  double hybrid_gain = 100.0;      // [N s/cm], kHybrid
  double hybrid_alpha = 0.5;       // kHybrid blend in [0, 1]: 1 skyhook, 0 groundhook
  double sh_add_alpha = 9.42;      // [rad/s], kSkyhookAdd crossover (2 pi 1.5 Hz), > 0
  ClippedCommand clipped_command = ClippedCommand::kClipped;  // kClippedOptimal
  // True when the values are finite and in range (constant voltage in [e_min, e_max]).
  bool IsValid(double e_min, double e_max) const;
};

struct ControlInputs {
  Real v = Real(0);                  // relative (damper) velocity [cm/s]
  Real demand = Real(0);             // force demand [N] (kForceTracking)
  Real body_velocity = Real(0);      // [cm/s] (skyhook, hybrid, SH-ADD)
  Real wheel_velocity = Real(0);     // [cm/s] (groundhook, hybrid)
  Real body_acceleration = Real(0);  // [cm/s^2] (ADD, SH-ADD)
};

struct ControlOutput {
  bool is_force = true;  // true: value is a force demand to invert; false: a voltage
  Real value = Real(0);  // [N] or [V]
};

// Stateless control law. Real-time safe.
class ControlLaw {
 public:
  void Configure(const ControlLawConfig& config, double e_min, double e_max) {
    config_ = config;
    constant_voltage_ = static_cast<Real>(config.constant_voltage);
    skyhook_gain_ = static_cast<Real>(config.skyhook_gain);
    force_limit_ = static_cast<Real>(config.force_limit);
    groundhook_gain_ = static_cast<Real>(config.groundhook_gain);
    hybrid_gain_ = static_cast<Real>(config.hybrid_gain);
    hybrid_alpha_ = static_cast<Real>(config.hybrid_alpha);
    sh_add_alpha2_ = static_cast<Real>(config.sh_add_alpha * config.sh_add_alpha);
    e_min_ = static_cast<Real>(e_min);
    e_max_ = static_cast<Real>(e_max);
  }
  // Real-time safe.
  ControlOutput Update(const ControlInputs& in) const;
  const ControlLawConfig& config() const { return config_; }
  bool needs_demand() const {
    return config_.mode == ControlMode::kForceTracking || config_.mode == ControlMode::kOpenLoop;
  }
  bool needs_body_velocity() const { return NeedsBodyVelocity(config_.mode); }
  bool needs_wheel_velocity() const { return NeedsWheelVelocity(config_.mode); }
  bool needs_body_acceleration() const { return NeedsBodyAcceleration(config_.mode); }
  static bool NeedsBodyVelocity(ControlMode m) {
    return m == ControlMode::kSkyhookOnOff || m == ControlMode::kSkyhookContinuous ||
           m == ControlMode::kHybrid || m == ControlMode::kSkyhookAdd;
  }
  static bool NeedsWheelVelocity(ControlMode m) {
    return m == ControlMode::kGroundhook || m == ControlMode::kGroundhookOnOff ||
           m == ControlMode::kHybrid;
  }
  static bool NeedsBodyAcceleration(ControlMode m) {
    return m == ControlMode::kAdd || m == ControlMode::kSkyhookAdd;
  }
  // The clipped-optimal law reads the three floor accelerations and the measured force.
  static bool NeedsFloorAccelerations(ControlMode m) { return m == ControlMode::kClippedOptimal; }
  static bool NeedsForce(ControlMode m) { return m == ControlMode::kClippedOptimal; }

 private:
  ControlLawConfig config_;
  Real constant_voltage_ = Real(0);  // config_ in Real
  Real skyhook_gain_ = Real(100);
  Real force_limit_ = Real(5000);
  Real groundhook_gain_ = Real(100);
  Real hybrid_gain_ = Real(100);
  Real hybrid_alpha_ = Real(0.5);
  Real sh_add_alpha2_ = Real(88.7);  // a^2 [rad^2/s^2]
  Real e_min_ = Real(0);
  Real e_max_ = Real(2.25);
};

// Name for logs and telemetry ("force", "constant", "skyhook-on-off", "skyhook", "open-loop",
// "groundhook", "groundhook-on-off", "hybrid", "add", "sh-add", "clipped-optimal").
const char* ControlModeName(ControlMode mode);

}  // namespace mrd::firmware
