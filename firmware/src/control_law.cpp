#include "mrd/firmware/control_law.hpp"

#include <cmath>

namespace mrd::firmware {

bool ControlLawConfig::IsValid(double e_min, double e_max) const {
  if (!std::isfinite(constant_voltage) || !std::isfinite(skyhook_gain) ||
      !std::isfinite(force_limit) || !std::isfinite(groundhook_gain) ||
      !std::isfinite(hybrid_gain) || !std::isfinite(hybrid_alpha) || !std::isfinite(sh_add_alpha)) {
    return false;
  }
  if (groundhook_gain < 0.0 || hybrid_gain < 0.0 || hybrid_alpha < 0.0 || hybrid_alpha > 1.0 ||
      sh_add_alpha <= 0.0) {
    return false;
  }
  if (mode == ControlMode::kConstantVoltage &&
      (constant_voltage < e_min || constant_voltage > e_max)) {
    return false;
  }
  return skyhook_gain >= 0.0 && force_limit > 0.0 &&
         static_cast<std::uint8_t>(mode) <=
             static_cast<std::uint8_t>(ControlMode::kClippedOptimal) &&
         static_cast<std::uint8_t>(clipped_command) <=
             static_cast<std::uint8_t>(ClippedCommand::kInverse);
}

ControlOutput ControlLaw::Update(const ControlInputs& in) const {
  const auto clamp = [this](Real f) {
    return std::fmin(std::fmax(f, -force_limit_), force_limit_);
  };
  switch (config_.mode) {
    case ControlMode::kForceTracking:
      return {true, clamp(in.demand)};
    case ControlMode::kConstantVoltage:
      return {false, constant_voltage_};
    case ControlMode::kSkyhookOnOff:
      return {false, in.body_velocity * in.v > Real(0) ? e_max_ : e_min_};
    case ControlMode::kSkyhookContinuous: {
      const Real f = in.body_velocity * in.v > Real(0) ? skyhook_gain_ * in.body_velocity : Real(0);
      return {true, clamp(f)};
    }
    case ControlMode::kOpenLoop:  // mV on the demand input; the controller clamps the volts
      return {false, in.demand * Real(1e-3)};
    case ControlMode::kGroundhook: {
      // Groundhook force on the wheel -c vw; the damper pushes the wheel with +f (per motion
      // ratio): f = -c vw, possible when it has f's passive sign (-vw v > 0).
      const Real f =
          -in.wheel_velocity * in.v > Real(0) ? -groundhook_gain_ * in.wheel_velocity : Real(0);
      return {true, clamp(f)};
    }
    case ControlMode::kGroundhookOnOff:
      return {false, -in.wheel_velocity * in.v > Real(0) ? e_max_ : e_min_};
    case ControlMode::kHybrid: {
      const Real sky = in.body_velocity * in.v > Real(0) ? in.body_velocity : Real(0);
      const Real gnd = -in.wheel_velocity * in.v > Real(0) ? -in.wheel_velocity : Real(0);
      return {true, clamp(hybrid_gain_ * (hybrid_alpha_ * sky + (Real(1) - hybrid_alpha_) * gnd))};
    }
    case ControlMode::kAdd:
      return {false, in.body_acceleration * in.v > Real(0) ? e_max_ : e_min_};
    case ControlMode::kSkyhookAdd: {
      // Savaresi & Spelta 2007: the sign of ab^2 - a^2 vb^2 picks the band (<= 0: the motion
      // is slow against a, skyhook; > 0: fast, ADD).
      const Real ab = in.body_acceleration, vb = in.body_velocity;
      const bool slow = ab * ab - sh_add_alpha2_ * vb * vb <= Real(0);
      const bool on = slow ? vb * in.v > Real(0) : ab * in.v > Real(0);
      return {false, on ? e_max_ : e_min_};
    }
    case ControlMode::kClippedOptimal:  // decided by ClippedOptimal (clipped_optimal.hpp)
      return {false, e_min_};
  }
  return {false, e_min_};
}

const char* ControlModeName(ControlMode mode) {
  switch (mode) {
    case ControlMode::kForceTracking:
      return "force";
    case ControlMode::kConstantVoltage:
      return "constant";
    case ControlMode::kSkyhookOnOff:
      return "skyhook-on-off";
    case ControlMode::kSkyhookContinuous:
      return "skyhook";
    case ControlMode::kOpenLoop:
      return "open-loop";
    case ControlMode::kGroundhook:
      return "groundhook";
    case ControlMode::kGroundhookOnOff:
      return "groundhook-on-off";
    case ControlMode::kHybrid:
      return "hybrid";
    case ControlMode::kAdd:
      return "add";
    case ControlMode::kSkyhookAdd:
      return "sh-add";
    case ControlMode::kClippedOptimal:
      return "clipped-optimal";
  }
  return "unknown";
}

}  // namespace mrd::firmware
