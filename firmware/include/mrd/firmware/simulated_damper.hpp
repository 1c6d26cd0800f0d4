#pragma once
// The dry-run plant: the Spencer reference damper (common/) behind the same SensorSource and
// CurrentDriver interfaces as the bus drivers, so the loop cannot tell them apart.
//
// Excitation: relative displacement x(t) = A sin(2 pi f t) [cm], v = dx/dt [cm/s]; the force
// demand d(t) = D (0.65 + 0.35 sin(2 pi f_d t)) tanh(v / 2 cm/s) [N] (dissipative, as a
// semi-active damper can deliver); body velocity vb(t) = B sin(2 pi f_b t + phi) [cm/s].
// The plant advances to the clock's time in whole periods at each Read, with the last
// commanded voltage held (zero-order hold), and reports samples stamped at its own time.

#include <cstdint>

#include "mrd/common/spencer_damper.hpp"
#include "mrd/firmware/io.hpp"

namespace mrd::firmware {

struct SimulationConfig {
  double amplitude_cm = 1.0;         // A
  double frequency_hz = 2.0;         // f
  double demand_amplitude_n = 1200.0; // D
  double demand_frequency_hz = 0.5;  // f_d
  double body_amplitude = 8.0;       // B [cm/s]
  double body_frequency_hz = 1.3;    // f_b
  double body_phase_rad = 0.7;       // phi
  int substeps = 20;                 // RK4 steps per period (dry-run accuracy is enough)
};

class SimulatedDamper final : public SensorSource, public CurrentDriver {
 public:
  // clock: the loop's clock (not owned; outlives this); period_ns > 0.
  SimulatedDamper(const SpencerParams& params, const SimulationConfig& config, Clock& clock,
                  std::int64_t period_ns);
  SimulatedDamper(const SimulatedDamper&) = delete;
  SimulatedDamper& operator=(const SimulatedDamper&) = delete;

  // Real-time safe (fixed-step integration, bounded by the elapsed periods, at most 1000 per
  // call — a longer gap restarts the plant time).
  IoStatus Read(SensorFrame* frame) override;
  IoStatus Command(double volts) override;
  IoStatus EnterSafeState(double safe_volts) override;

  double held_volts() const { return volts_; }
  bool in_safe_state() const { return safe_; }
  std::uint64_t commands() const { return commands_; }
  double force() const { return force_; }

 private:
  double X(double t) const;
  double V(double t) const;
  void Advance(std::int64_t to_ns);

  SpencerDamper damper_;
  SimulationConfig config_;
  Clock& clock_;
  std::int64_t period_ns_;
  std::int64_t start_ns_;
  std::int64_t plant_ns_;  // time of the plant state
  double force_ = 0.0;
  double volts_ = 0.0;
  bool safe_ = true;
  std::uint64_t commands_ = 0;
};

}  // namespace mrd::firmware
