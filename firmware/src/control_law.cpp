#include "mrd/firmware/control_law.hpp"

#include <cmath>

namespace mrd::firmware {

bool ControlLawConfig::IsValid(double e_min, double e_max) const {
  if (!std::isfinite(constant_voltage) || !std::isfinite(skyhook_gain) ||
      !std::isfinite(force_limit)) {
    return false;
  }
  if (mode == ControlMode::kConstantVoltage &&
      (constant_voltage < e_min || constant_voltage > e_max)) {
    return false;
  }
  return skyhook_gain >= 0.0 && force_limit > 0.0 &&
         static_cast<std::uint8_t>(mode) <= static_cast<std::uint8_t>(ControlMode::kOpenLoop);
}

ControlOutput ControlLaw::Update(const ControlInputs& in) const {
  switch (config_.mode) {
    case ControlMode::kForceTracking:
      return {true, std::fmin(std::fmax(in.demand, -force_limit_), force_limit_)};
    case ControlMode::kConstantVoltage:
      return {false, constant_voltage_};
    case ControlMode::kSkyhookOnOff:
      return {false, in.body_velocity * in.v > Real(0) ? e_max_ : e_min_};
    case ControlMode::kSkyhookContinuous: {
      const Real f = in.body_velocity * in.v > Real(0) ? skyhook_gain_ * in.body_velocity : Real(0);
      return {true, std::fmin(std::fmax(f, -force_limit_), force_limit_)};
    }
    case ControlMode::kOpenLoop:  // mV on the demand input; the controller clamps the volts
      return {false, in.demand * Real(1e-3)};
    case ControlMode::kClippedOptimal:  // decided by ClippedOptimal (clipped_optimal.hpp)
      return {false, e_min_};
  }
  return {false, e_min_};
}

const char* ControlModeName(ControlMode mode) {
  switch (mode) {
    case ControlMode::kForceTracking: return "force";
    case ControlMode::kConstantVoltage: return "constant";
    case ControlMode::kSkyhookOnOff: return "skyhook-on-off";
    case ControlMode::kSkyhookContinuous: return "skyhook";
    case ControlMode::kOpenLoop: return "open-loop";
    case ControlMode::kClippedOptimal: return "clipped-optimal";
  }
  return "unknown";
}

}  // namespace mrd::firmware
