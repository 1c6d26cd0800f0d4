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
         static_cast<std::uint8_t>(mode) <= static_cast<std::uint8_t>(ControlMode::kSkyhookContinuous);
}

ControlOutput ControlLaw::Update(const ControlInputs& in) const {
  switch (config_.mode) {
    case ControlMode::kForceTracking:
      return {true, std::fmin(std::fmax(in.demand, -config_.force_limit), config_.force_limit)};
    case ControlMode::kConstantVoltage:
      return {false, config_.constant_voltage};
    case ControlMode::kSkyhookOnOff:
      return {false, in.body_velocity * in.v > 0.0 ? e_max_ : e_min_};
    case ControlMode::kSkyhookContinuous: {
      const double f = in.body_velocity * in.v > 0.0 ? config_.skyhook_gain * in.body_velocity : 0.0;
      return {true, std::fmin(std::fmax(f, -config_.force_limit), config_.force_limit)};
    }
  }
  return {false, e_min_};
}

const char* ControlModeName(ControlMode mode) {
  switch (mode) {
    case ControlMode::kForceTracking: return "force";
    case ControlMode::kConstantVoltage: return "constant";
    case ControlMode::kSkyhookOnOff: return "skyhook-on-off";
    case ControlMode::kSkyhookContinuous: return "skyhook";
  }
  return "unknown";
}

}  // namespace mrd::firmware
