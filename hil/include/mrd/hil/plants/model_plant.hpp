#pragma once
// An identified NARX model as the plant (`[plant] model = "narx"`, file, iteration): the model
// plays the damper. The excitation still prescribes the motion (x, v) and the demand; the
// force the sensors read is the model's free-run output given that motion and the applied
// command E, fed back as its own output history (as `mrd simulate` and the firmware run it).
//
// Operating envelope: when the model file records each channel's identification range
// (min, max), the model's inputs v, x, E are held to [min - m, max + m], m = margin *
// (max - min), before it sees them, and its fed-back force the same way (as the firmware's
// ModelRuntime does with the table's envelope). Every held sample is counted: input_holds
// (any of v, x, E held) and force_holds; the run summary reports them.

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "mrd/common/model.hpp"
#include "mrd/hil/plants/plant.hpp"

namespace mrd::hil {

struct PlantModel {
  std::string file;            // the model file (as resolved against the scenario)
  int iteration = 0;           // the iteration played
  Model model;                 // channels: output (force) first, then those the terms read
  int v = -1, x = -1, e = -1;  // channel of velocity, displacement, command (-1: not read)
  bool has_envelope = false;
  std::array<double, kMaxChannels> lo{}, hi{};  // envelope with margin [raw units]
};

// Reads an `mrd identify` model file (JSON) and builds the runtime model of one iteration
// (-1: the file's selected one) the way `mrd export` does (same channel order, regressors
// and coefficients). The model may read only v, x and E besides its output, and must read E.
// margin: fraction of each channel's range added on both sides of the envelope (>= 0).
// false: *error = the reason (no file or line prefix; the caller adds the scenario's).
bool LoadPlantModel(const std::string& path, int iteration, double margin, PlantModel* out,
                    std::string* error);

// Samples held to the envelope (model_plant.hpp header comment).
struct PlantHolds {
  std::uint64_t input_holds = 0;  // samples with v, x or E held
  std::uint64_t force_holds = 0;  // samples with the fed-back force held
};

// The model on the motion of another plant (its force is ignored): Step(volts) steps the
// motion, then the model with E = volts. Real-time safe after construction.
class ModelPlant final : public Plant {
 public:
  ModelPlant(std::shared_ptr<const PlantModel> model, std::unique_ptr<Plant> motion);
  void Reset() override;
  PlantSample Step(double volts) override;
  PlantSample Sample() const override;
  PlantSample Probe(double volts) const override;
  const PlantHolds* Holds() const override { return &holds_; }

 private:
  // The model's force for motion sample s and command volts on runner (advanced when
  // finish); counts holds into *holds when given.
  double Force(ModelRunner* runner, const PlantSample& s, double volts, bool finish,
               PlantHolds* holds) const;

  std::shared_ptr<const PlantModel> pm_;
  std::unique_ptr<Plant> motion_;
  ModelRunner runner_;
  PlantSample sample_;
  PlantHolds holds_;
};

}  // namespace mrd::hil
