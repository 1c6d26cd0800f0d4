#include "mrd/hil/structure_plant.hpp"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "mrd/common/input_file.hpp"

namespace mrd::hil {

bool LoadGroundRecord(const std::string& path, GroundRecord* record, std::string* error) {
  std::string text;
  if (!ReadInputFile(path, std::uint64_t{64} << 20, &text, error)) return false;
  const std::string where = Printable(path);
  std::istringstream in(text);
  std::vector<double> t, a;
  std::string line;
  int number = 0;
  bool header = false;
  const auto fail = [&](const std::string& why) {
    *error = where + ":" + std::to_string(number) + ": " + why;
    return false;
  };
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;
      if (line.rfind("t_s,ag_g", 0) != 0) return fail("expected the header t_s,ag_g");
      continue;
    }
    const char* s = line.c_str();
    char* end = nullptr;
    const double tv = std::strtod(s, &end);
    if (end == s || *end != ',') return fail("expected 't_s,ag_g' numbers");
    const char* s2 = end + 1;
    const double av = std::strtod(s2, &end);
    while (*end == ' ') ++end;
    if (end == s2 || *end != '\0' || !std::isfinite(tv) || !std::isfinite(av)) {
      return fail("expected 't_s,ag_g' numbers");
    }
    if (std::fabs(av) > 10.0) return fail("ground acceleration beyond 10 g");
    if (t.size() >= 2) {
      const double dt = t[1] - t[0];
      if (std::fabs((tv - t.back()) - dt) > 1e-6 * (1.0 + dt)) {
        return fail("samples are not equally spaced");
      }
    } else if (!t.empty() && !(tv > t.back())) {
      return fail("time does not increase");
    }
    t.push_back(tv);
    a.push_back(av);
  }
  if (t.size() < 2) {
    *error = where + ": fewer than 2 samples";
    return false;
  }
  record->path = path;
  record->ag_g = std::move(a);
  record->dt_s = t[1] - t[0];
  return true;
}

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
