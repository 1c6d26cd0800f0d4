#pragma once
// The three-story structure as a harness plant ([plant] model = "structure"): the shear frame
// of common/sim/ (shear_frame.hpp, Dyke et al. 1996) with the Spencer damper between the ground and
// the first floor, excited by a ground-acceleration record (El Centro 1940 NS:
// hil/data/el_centro_1940_ns.csv) played time_scale times faster at amplitude times its
// level, linear between samples, still ground after its end. The same arithmetic as the
// in-process study (mrd-structure study; docs/structure.md).
//
// Sample: x, v = the damper's stroke and velocity (100 x1 [cm], 100 x1' [cm/s]); force = the
// damper force [N]; floor_acceleration = the absolute floor accelerations [m/s^2];
// has_structure. Structure() gives the floors (displacements, drifts, accelerations) scored.

#include <memory>
#include <string>
#include <vector>

#include "mrd/common/ground_record.hpp"
#include "mrd/hil/plants/plant.hpp"
#include "mrd/sim/shear_frame.hpp"

namespace mrd::hil {

struct StructureSetup {
  GroundRecord record;
  double time_scale = 5.0;  // the record is played this many times faster (scaled model)
  double amplitude = 1.0;   // factor on the record's acceleration
  double g = 9.81;          // [m/s^2]
  ShearFrameParams frame;   // Dyke et al.'s frame
  // The scaled record's length [s].
  double RecordSeconds() const {
    return record.dt_s / time_scale * static_cast<double>(record.ag_g.size() - 1);
  }
};

class StructurePlant final : public Plant {
 public:
  // setup must outlive the plant (shared). period_s: the control period; substeps: RK4 steps
  // of frame and damper per period.
  StructurePlant(std::shared_ptr<const StructureSetup> setup, const SpencerParams& damper,
                 double period_s, int substeps);
  void Reset() override;
  PlantSample Step(double volts) override;  // allocation-free
  PlantSample Sample() const override { return sample_; }
  PlantSample Probe(double volts) const override;  // steps a copy (a value type)
  const ShearFrameSample* Structure() const override { return &frame_.sample(); }
  // Ground acceleration at plant time t [m/s^2].
  double GroundAcceleration(double t) const;

 private:
  PlantSample SampleOf(const ShearFrameSample& s, double t) const;

  std::shared_ptr<const StructureSetup> setup_;
  double period_s_;
  ShearFrame frame_;
  std::int64_t steps_ = 0;
  PlantSample sample_;
};

}  // namespace mrd::hil
