// The plant's checks: [plant] files, structure, NARX model, quarter car (scenario_reader.hpp).
#include <sys/stat.h>

#include "mrd/common/file_path.hpp"
#include "mrd/hil/plants/model_plant.hpp"
#include "plant_params.hpp"
#include "scenario_reader.hpp"

namespace mrd::hil::scenario_reader {

// [plant] params or preset, the damper they give, the [firmware] table file.
bool ScenarioReader::CheckPlantFiles() {
  const std::string& path = path_;
  if (!s.params_file.empty() && root_.at_path("plant.preset").node() != nullptr) {
    return c_.Fail(*root_.at_path("plant.params").node(),
                   "[plant] params and preset exclude each other (the file may name a preset)");
  }
  if (!s.params_file.empty()) s.params_file = ResolveBeside(path, s.params_file);
  if (!ResolvePlantDamper(path, root_, spencer_, &s, error_)) return false;
  if (!s.table_file.empty()) {
    s.table_file = ResolveBeside(path, s.table_file);
    struct stat st {};
    if (stat(s.table_file.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
      return c_.Fail(at("firmware.table"),
                     "[firmware] table '" + s.table_file + "': not a readable file");
    }
  }
  return true;
}

// model = "structure": its [structure] record; the structure-only [pass] keys.
bool ScenarioReader::CheckStructure() {
  Ctx& c = c_;
  if (model_ != "damper" && model_ != "quarter-car" && model_ != "full-car" && model_ != "narx" &&
      model_ != "structure") {
    return c.Fail(at("plant.model"),
                  "plant model must be \"damper\", \"quarter-car\", \"full-car\", "
                  "\"narx\" or \"structure\"");
  }
  s.structure = model_ == "structure";
  if (!s.structure && root_.contains("structure")) {
    return c.Fail(at("structure"), "[structure] needs [plant] model = \"structure\"");
  }
  if (s.structure) {
    if (record_file_.empty()) {
      return c.Fail(root_.contains("structure") ? at("structure") : at("plant.model"),
                    "model = \"structure\" needs [structure] record (a t_s,ag_g CSV, e.g. "
                    "../data/el_centro_1940_ns.csv)");
    }
    record_file_ = ResolveBeside(path_, record_file_);
    std::string why;
    if (!LoadGroundRecord(record_file_, &structure_->record, &why)) {
      return c.Fail(at("structure.record"), "[structure] record: " + why);
    }
    if (root_.contains("excitation")) {
      return c.Fail(at("excitation"),
                    "a structure is excited by its [structure] record, not [excitation]");
    }
    s.structure_setup = structure_;
  } else if (s.peak_drift_below_passive_on || s.peak_accel_below_passive_on ||
             max_peak_force_ >= 0.0) {
    const char* key = s.peak_drift_below_passive_on   ? "pass.peak_drift_below_passive_on"
                      : s.peak_accel_below_passive_on ? "pass.peak_accel_below_passive_on"
                                                      : "pass.max_peak_force_n";
    return c.Fail(at(key), std::string("'") + (key + 5) + "' needs [plant] model = \"structure\"");
  }
  if (max_peak_force_ >= 0.0) s.max_peak_force_n = max_peak_force_;
  return true;
}

// model = "narx": the identified model file; its keys need that model.
bool ScenarioReader::CheckNarx() {
  Ctx& c = c_;
  if (model_ != "narx" &&
      (!model_file_.empty() || has("plant.iteration") || has("plant.envelope_margin"))) {
    const char* key = !model_file_.empty()     ? "plant.file"
                      : has("plant.iteration") ? "plant.iteration"
                                               : "plant.envelope_margin";
    return c.Fail(at(key), std::string("'") + (key + 6) + "' needs [plant] model = \"narx\"");
  }
  if (model_ != "narx") return true;
  if (model_file_.empty()) {
    return c.Fail(at("plant.model"), "model = \"narx\" needs 'file' (an mrd identify model)");
  }
  model_file_ = ResolveBeside(path_, model_file_);
  auto pm = std::make_shared<PlantModel>();
  std::string why;
  if (!LoadPlantModel(model_file_, model_iteration_, envelope_margin_, pm.get(), &why)) {
    const bool iteration_problem = why.find(": no iteration ") != std::string::npos;
    return c.Fail(
        at(iteration_problem && has("plant.iteration") ? "plant.iteration" : "plant.file"),
        "plant model: " + why);
  }
  s.plant_model = std::move(pm);
  return true;
}

// model = "quarter-car": [quarter_car] and [road]; the quarter-car-only [pass] keys.
bool ScenarioReader::CheckQuarterCar() {
  Ctx& c = c_;
  QuarterCarParams& car = s.car;
  RoadParams& road = s.road;
  s.quarter_car = model_ == "quarter-car";
  if (!s.quarter_car &&
      (root_.contains("quarter_car") || (root_.contains("road") && model_ != "full-car"))) {
    return c.Fail(root_.contains("road") ? at("road") : at("quarter_car"),
                  "[quarter_car] and [road] need [plant] model = \"quarter-car\"");
  }
  if (s.quarter_car) {
    if (road_class_.size() != 1 || !RoadClassFromChar(road_class_[0], &road.road_class)) {
      return c.Fail(at("road.class"), "road class must be one of A .. H");
    }
    const char* why = nullptr;
    if (!road.IsValid(&why)) return c.Fail(at("road"), std::string("[road]: ") + why);
    car.max_volts = s.e_max;
    if (!car.IsValid(&why)) return c.Fail(at("quarter_car"), std::string("[quarter_car]: ") + why);
    if (root_.contains("excitation")) {
      return c.Fail(at("excitation"), "a quarter car is excited by its [road], not [excitation]");
    }
    if (s.ride_settle_s >= s.duration_s) {
      return c.Fail(at("quarter_car.settle_s"), "settle_s must be shorter than duration_s");
    }
    if (s.passive_step_v > 0.0 && s.e_max / s.passive_step_v > 10000.0) {
      return c.Fail(at("quarter_car.passive_step_v"),
                    "passive_step_v gives more than 10000 grid points over 0 .. e_max");
    }
  } else if (s.body_accel_below_passive) {
    return c.Fail(at("pass.body_accel_below_passive"),
                  "body_accel_below_passive needs [plant] model = \"quarter-car\"");
  } else if (s.tyre_load_below_passive_off) {
    return c.Fail(at("pass.tyre_load_below_passive_off"),
                  "tyre_load_below_passive_off needs [plant] model = \"quarter-car\"");
  }
  return true;
}

}  // namespace mrd::hil::scenario_reader
