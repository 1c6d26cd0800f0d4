#pragma once
// The dry-run plant: the reference damper plant (mrd/sim/damper_plant.hpp, the one the HIL
// harness serves) behind the same SensorSource and CurrentDriver interfaces as the bus
// drivers, so the loop cannot tell them apart. The plant advances to the clock's time in whole
// periods at each Read, with the last commanded voltage held (zero-order hold), and reports
// samples stamped at its own time.

#include <cstdint>

#include "mrd/firmware/io.hpp"
#include "mrd/sim/damper_plant.hpp"

namespace mrd::firmware {

using SimulationConfig = PlantExcitation;  // excitation of the dry-run plant

class SimulatedDamper final : public SensorSource, public CurrentDriver {
 public:
  // clock: the loop's clock (not owned; outlives this); period_ns > 0.
  SimulatedDamper(const SpencerParams& params, const SimulationConfig& config, Clock& clock,
                  std::int64_t period_ns);
  SimulatedDamper(const SimulatedDamper&) = delete;
  SimulatedDamper& operator=(const SimulatedDamper&) = delete;

  // Real-time safe (fixed-step integration, bounded by the elapsed periods, at most 1000 per
  // call — a longer gap is skipped: the plant resumes where it stopped).
  IoStatus Read(const IoTime& t, SensorFrame* frame) override;
  IoStatus Command(const IoTime& t, double volts) override;
  IoStatus EnterSafeState(const IoTime& t, double safe_volts) override;

  double held_volts() const { return volts_; }
  bool in_safe_state() const { return safe_; }
  std::uint64_t commands() const { return commands_; }
  double force() const { return sample_.force; }

 private:
  void Advance(std::int64_t to_ns);

  DamperPlant plant_;
  Clock& clock_;
  std::int64_t period_ns_;
  std::int64_t plant_ns_;  // time of the plant state
  PlantSample sample_;
  double volts_ = 0.0;
  bool safe_ = true;
  std::uint64_t commands_ = 0;
};

}  // namespace mrd::firmware
