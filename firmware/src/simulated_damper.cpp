#include "mrd/firmware/simulated_damper.hpp"

#include <cmath>
#include <numbers>

namespace mrd::firmware {
namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr std::int64_t kMaxCatchUp = 1000;  // periods per Read
}  // namespace

SimulatedDamper::SimulatedDamper(const SpencerParams& params, const SimulationConfig& config,
                                 Clock& clock, std::int64_t period_ns)
    : damper_(params, config.substeps),
      config_(config),
      clock_(clock),
      period_ns_(period_ns),
      start_ns_(clock.Now()),
      plant_ns_(start_ns_) {
  damper_.Reset(X(0.0), 0.0);
  force_ = damper_.Force(X(0.0), V(0.0));
}

double SimulatedDamper::X(double t) const {
  return config_.amplitude_cm * std::sin(kTwoPi * config_.frequency_hz * t);
}

double SimulatedDamper::V(double t) const {
  return config_.amplitude_cm * kTwoPi * config_.frequency_hz *
         std::cos(kTwoPi * config_.frequency_hz * t);
}

void SimulatedDamper::Advance(std::int64_t to_ns) {
  std::int64_t steps = (to_ns - plant_ns_) / period_ns_;
  if (steps > kMaxCatchUp) {  // a long stall: skip ahead instead of integrating it all
    plant_ns_ += (steps - kMaxCatchUp) * period_ns_;
    steps = kMaxCatchUp;
  }
  const double dt = static_cast<double>(period_ns_) * 1e-9;
  for (std::int64_t i = 0; i < steps; ++i) {
    const double t0 = static_cast<double>(plant_ns_ - start_ns_) * 1e-9;
    const double t1 = t0 + dt;
    force_ = damper_.Step(dt, X(t0), V(t0), X(t1), V(t1), volts_);
    plant_ns_ += period_ns_;
  }
}

IoStatus SimulatedDamper::Read(SensorFrame* frame) {
  Advance(clock_.Now());
  const double t = static_cast<double>(plant_ns_ - start_ns_) * 1e-9;
  frame->displacement = {X(t), plant_ns_};
  frame->velocity = {V(t), plant_ns_};
  // A semi-active damper only dissipates: the demand follows the sign of v (smoothly, over
  // ~2 cm/s) with a magnitude swinging between 0.3 D and D.
  const double level = 0.65 + 0.35 * std::sin(kTwoPi * config_.demand_frequency_hz * t);
  frame->demand = {config_.demand_amplitude_n * level * std::tanh(V(t) / 2.0), plant_ns_};
  frame->body_velocity = {
      config_.body_amplitude *
          std::sin(kTwoPi * config_.body_frequency_hz * t + config_.body_phase_rad),
      plant_ns_};
  frame->force = {force_, plant_ns_};
  frame->fault_line = false;
  return IoStatus::kOk;
}

IoStatus SimulatedDamper::Command(double volts) {
  volts_ = volts;
  safe_ = false;
  ++commands_;
  return IoStatus::kOk;
}

IoStatus SimulatedDamper::EnterSafeState(double safe_volts) {
  volts_ = safe_volts;
  safe_ = true;
  ++commands_;
  return IoStatus::kOk;
}

}  // namespace mrd::firmware
