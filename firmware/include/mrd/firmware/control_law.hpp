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
//
// vb: absolute body velocity [cm/s]; c_sky: skyhook gain [N s/cm].

#include <cstdint>

namespace mrd::firmware {

enum class ControlMode : std::uint8_t {
  kForceTracking = 0,
  kConstantVoltage,
  kSkyhookOnOff,
  kSkyhookContinuous,
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
  double v = 0.0;              // relative (damper) velocity [cm/s]
  double demand = 0.0;         // force demand [N] (kForceTracking)
  double body_velocity = 0.0;  // [cm/s] (skyhook)
};

struct ControlOutput {
  bool is_force = true;  // true: value is a force demand to invert; false: a voltage
  double value = 0.0;    // [N] or [V]
};

// Stateless control law. Real-time safe.
class ControlLaw {
 public:
  void Configure(const ControlLawConfig& config, double e_min, double e_max) {
    config_ = config;
    e_min_ = e_min;
    e_max_ = e_max;
  }
  // Real-time safe.
  ControlOutput Update(const ControlInputs& in) const;
  const ControlLawConfig& config() const { return config_; }
  bool needs_demand() const { return config_.mode == ControlMode::kForceTracking; }
  bool needs_body_velocity() const {
    return config_.mode == ControlMode::kSkyhookOnOff ||
           config_.mode == ControlMode::kSkyhookContinuous;
  }

 private:
  ControlLawConfig config_;
  double e_min_ = 0.0;
  double e_max_ = 2.25;
};

// Name for logs and telemetry ("force", "constant", "skyhook-on-off", "skyhook").
const char* ControlModeName(ControlMode mode);

}  // namespace mrd::firmware
