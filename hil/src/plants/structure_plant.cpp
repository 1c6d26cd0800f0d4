#include "mrd/hil/plants/structure_plant.hpp"

#include <cmath>

namespace mrd::hil {

StructurePlant::StructurePlant(std::shared_ptr<const StructureSetup> setup,
                               const SpencerParams& damper, double period_s, int substeps)
    : setup_(std::move(setup)), period_s_(period_s), frame_(setup_->frame, damper, substeps) {
  Reset();
}

double StructurePlant::GroundAcceleration(double t) const {
  const StructureSetup& s = *setup_;
  const double dt = s.record.dt_s / s.time_scale;
  if (t >= s.RecordSeconds() || t < 0.0) return 0.0;
  const double pos = t / dt;
  const auto i = static_cast<std::size_t>(pos);
  const double w = pos - static_cast<double>(i);
  return s.amplitude * s.g * (s.record.ag_g[i] * (1.0 - w) + s.record.ag_g[i + 1] * w);
}

PlantSample StructurePlant::SampleOf(const ShearFrameSample& f, double t) const {
  PlantSample p;
  p.t_s = t;
  p.x = 100.0 * f.x[0];
  p.v = 100.0 * f.v[0];
  p.force = f.force;
  for (int i = 0; i < 3; ++i) p.floor_acceleration[i] = f.xa[i];
  p.has_structure = true;
  return p;
}

void StructurePlant::Reset() {
  steps_ = 0;
  frame_.Reset(0.0, GroundAcceleration(0.0));
  sample_ = SampleOf(frame_.sample(), 0.0);
}

PlantSample StructurePlant::Step(double volts) {
  const double t0 = static_cast<double>(steps_) * period_s_;
  const ShearFrameSample& f =
      frame_.Step(period_s_, GroundAcceleration(t0), GroundAcceleration(t0 + period_s_), volts);
  ++steps_;
  sample_ = SampleOf(f, static_cast<double>(steps_) * period_s_);
  return sample_;
}

PlantSample StructurePlant::Probe(double volts) const {
  ShearFrame copy = frame_;
  const double t0 = static_cast<double>(steps_) * period_s_;
  return SampleOf(
      copy.Step(period_s_, GroundAcceleration(t0), GroundAcceleration(t0 + period_s_), volts),
      t0 + period_s_);
}

}  // namespace mrd::hil
