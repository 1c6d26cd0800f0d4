#include "mrd/sim/damper_plant.hpp"

#include <cmath>
#include <numbers>

namespace mrd {
namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
}  // namespace

DamperPlant::DamperPlant(const SpencerParams& params, const PlantExcitation& excitation,
                         double period_s)
    : damper_(params, excitation.substeps), excitation_(excitation), period_s_(period_s) {
  Reset();
}

void DamperPlant::Reset() {
  steps_ = 0;
  damper_.Reset(X(0.0), 0.0);
  force_ = damper_.Force(X(0.0), V(0.0));
}

double DamperPlant::X(double t) const {
  return excitation_.amplitude_cm * std::sin(kTwoPi * excitation_.frequency_hz * t);
}

double DamperPlant::V(double t) const {
  return excitation_.amplitude_cm * kTwoPi * excitation_.frequency_hz *
         std::cos(kTwoPi * excitation_.frequency_hz * t);
}

PlantSample DamperPlant::Step(double volts) {
  const double t0 = static_cast<double>(steps_) * period_s_;
  const double t1 = static_cast<double>(steps_ + 1) * period_s_;
  force_ = damper_.Step(period_s_, X(t0), V(t0), X(t1), V(t1), volts);
  ++steps_;
  return Sample();
}

PlantSample DamperPlant::Sample() const {
  const double t = static_cast<double>(steps_) * period_s_;
  PlantSample s;
  s.t_s = t;
  s.x = X(t);
  s.v = V(t);
  // A semi-active damper only dissipates: the demand follows the sign of v (smoothly, over
  // ~2 cm/s) with a magnitude swinging between 0.3 D and D.
  const double level = 0.65 + 0.35 * std::sin(kTwoPi * excitation_.demand_frequency_hz * t);
  s.demand = excitation_.demand_amplitude_n * level * std::tanh(s.v / 2.0);
  s.body_velocity =
      excitation_.body_amplitude *
      std::sin(kTwoPi * excitation_.body_frequency_hz * t + excitation_.body_phase_rad);
  s.body_acceleration =
      kTwoPi * excitation_.body_frequency_hz * excitation_.body_amplitude *
      std::cos(kTwoPi * excitation_.body_frequency_hz * t + excitation_.body_phase_rad);
  s.wheel_velocity = s.body_velocity - s.v;
  for (int i = 0; i < 3; ++i)
    s.floor_acceleration[i] = 0.01 * s.body_acceleration * (1.0 + 0.5 * i);
  s.force = force_;
  return s;
}

}  // namespace mrd
