#pragma once
// The plant a scenario drives, as the harness sees it: one Step(volts) per control period
// (voltage held) -> the sample its sensors read. DamperPlant (common/sim/) fits through an
// adapter; a trace-driven damper plays a recorded excitation (CSV x, v[, demand]); the quarter
// car of common/sim/ (damper between body and wheel on an ISO 8608 road) plugs in the same way
// and adds its ride figures through Ride() (body acceleration, suspension travel, tyre load).

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "mrd/sim/damper_plant.hpp"
#include "mrd/sim/quarter_car.hpp"
#include "mrd/sim/shear_frame.hpp"

namespace mrd::hil {

struct PlantHolds;  // model_plant.hpp

class Plant {
 public:
  virtual ~Plant() = default;
  // Back to t = 0.
  virtual void Reset() = 0;
  // Advances one period with volts [V] held; the sample at the end. Real-time safe.
  virtual PlantSample Step(double volts) = 0;
  virtual PlantSample Sample() const = 0;
  // The sample Step(volts) would give, without advancing (what the damper can deliver on the
  // next step from its present state: the harness's reachability test). No allocation.
  virtual PlantSample Probe(double volts) const = 0;
  // A vehicle plant's ride outputs at the present sample; nullptr for a damper alone.
  virtual const QuarterCarSample* Ride() const { return nullptr; }
  // The structure plant's floors at the present sample (structure_plant.hpp); nullptr else.
  virtual const ShearFrameSample* Structure() const { return nullptr; }
  // A model plant's envelope holds so far (model_plant.hpp); nullptr for the others.
  virtual const PlantHolds* Holds() const { return nullptr; }
};

// The reference damper on its periodic excitation (damper_plant.hpp).
class DamperPlantAdapter final : public Plant {
 public:
  DamperPlantAdapter(const SpencerParams& params, const PlantExcitation& excitation,
                     double period_s)
      : plant_(params, excitation, period_s) {}
  void Reset() override { plant_.Reset(); }
  PlantSample Step(double volts) override { return plant_.Step(volts); }
  PlantSample Sample() const override { return plant_.Sample(); }
  PlantSample Probe(double volts) const override {
    DamperPlant copy = plant_;  // value type: the damper state and the excitation
    return copy.Step(volts);
  }

 private:
  DamperPlant plant_;
};

// The quarter car on its road (quarter_car.hpp). Probe steps a copy kept beside the plant
// (copy-assigned: after the first probe no allocation, the road's vectors keep their size).
class QuarterCarAdapter final : public Plant {
 public:
  QuarterCarAdapter(const SpencerParams& damper, const QuarterCarParams& car,
                    const RoadParams& road, double period_s)
      : plant_(damper, car, road, period_s), probe_(plant_) {}
  void Reset() override { plant_.Reset(); }
  PlantSample Step(double volts) override { return plant_.Step(volts); }
  PlantSample Sample() const override { return plant_.Sample(); }
  PlantSample Probe(double volts) const override {
    probe_ = plant_;
    return probe_.Step(volts);
  }
  const QuarterCarSample* Ride() const override { return &plant_.Detail(); }

 private:
  QuarterCarPlant plant_;
  mutable QuarterCarPlant probe_;
};

// A recorded excitation, one row per period: displacement [cm], velocity [cm/s], force
// demand [N] (0 when the file has none). Past the end the last row holds.
struct Trace {
  std::vector<double> x, v, demand;
};

// The reference damper driven by a Trace (same Spencer model and zero-order hold as
// DamperPlant).
class TracePlant final : public Plant {
 public:
  TracePlant(const SpencerParams& params, Trace trace, double period_s, int substeps);
  void Reset() override;
  PlantSample Step(double volts) override;
  PlantSample Sample() const override;
  PlantSample Probe(double volts) const override;

 private:
  std::size_t Row(std::size_t k) const;

  SpencerDamper damper_;
  Trace trace_;
  double period_s_;
  std::size_t steps_ = 0;
  double force_ = 0.0;
};

// The harness plays a trace one row per control period [s].
inline constexpr double kTracePeriodS = 1e-3;

// Reads a CSV trace with a header row naming at least x and v (and optionally the demand
// column named demand_column, e.g. "f" of an `mrd generate` data set). A column t [s], when
// there is one, must step by kTracePeriodS (to 0.1 %) from row to row. false: *error =
// "FILE:LINE: reason"; a path that is not a regular file (FIFO, /dev/zero, a folder) or is
// over 256 MiB is refused before reading.
bool LoadTrace(const std::string& path, const std::string& demand_column, Trace* trace,
               std::string* error);

}  // namespace mrd::hil
