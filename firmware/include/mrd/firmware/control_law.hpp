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
//
// vb: absolute body velocity [cm/s]; c_sky: skyhook gain [N s/cm].
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
  // Clipped-optimal (clipped_optimal.hpp): a stateful observer-based law run by its own
  // object; the stateless ControlLaw holds E_min for it. Not yet a configurable [control] law
  // (ControlLawConfig::IsValid refuses it): the structure study runs it in process.
  kClippedOptimal,
};

struct ControlLawConfig {
  ControlMode mode = ControlMode::kForceTracking;
  double constant_voltage = 0.0;  // [V], kConstantVoltage
  double skyhook_gain = 100.0;    // [N s/cm], kSkyhookContinuous
  double force_limit = 5000.0;    // [N], |force demand| limit, > 0
  // True when the values are finite and in range (constant voltage in [e_min, e_max]).
  bool IsValid(double e_min, double e_max) const;
};

struct ControlInputs {
  Real v = Real(0);              // relative (damper) velocity [cm/s]
  Real demand = Real(0);         // force demand [N] (kForceTracking)
  Real body_velocity = Real(0);  // [cm/s] (skyhook)
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
    e_min_ = static_cast<Real>(e_min);
    e_max_ = static_cast<Real>(e_max);
  }
  // Real-time safe.
  ControlOutput Update(const ControlInputs& in) const;
  const ControlLawConfig& config() const { return config_; }
  bool needs_demand() const {
    return config_.mode == ControlMode::kForceTracking || config_.mode == ControlMode::kOpenLoop;
  }
  bool needs_body_velocity() const {
    return config_.mode == ControlMode::kSkyhookOnOff ||
           config_.mode == ControlMode::kSkyhookContinuous;
  }

 private:
  ControlLawConfig config_;
  Real constant_voltage_ = Real(0);  // config_ in Real
  Real skyhook_gain_ = Real(100);
  Real force_limit_ = Real(5000);
  Real e_min_ = Real(0);
  Real e_max_ = Real(2.25);
};

// Name for logs and telemetry ("force", "constant", "skyhook-on-off", "skyhook", "open-loop",
// "clipped-optimal").
const char* ControlModeName(ControlMode mode);

}  // namespace mrd::firmware
