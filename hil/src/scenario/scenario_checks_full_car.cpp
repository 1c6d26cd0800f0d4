// model = "full-car": the [full_car] keys and their checks (scenario_reader.hpp).
#include "mrd/sim/two_track_road.hpp"
#include "scenario_reader.hpp"

namespace mrd::hil::scenario_reader {

std::map<std::string, Setter> ScenarioReader::FullCarKeys() {
  FullCarParams& p = s.full;
  return {{"body_mass_kg", Num(&p.body_mass_kg, 1.0, 1e6, "body_mass_kg")},
          {"pitch_inertia_kg_m2", Num(&p.pitch_inertia_kg_m2, 1e-3, 1e8, "pitch_inertia_kg_m2")},
          {"roll_inertia_kg_m2", Num(&p.roll_inertia_kg_m2, 1e-3, 1e8, "roll_inertia_kg_m2")},
          {"cg_to_front_m", Num(&p.cg_to_front_m, 0.01, 100.0, "cg_to_front_m")},
          {"cg_to_rear_m", Num(&p.cg_to_rear_m, 0.01, 100.0, "cg_to_rear_m")},
          {"track_front_m", Num(&p.track_front_m, 0.01, 100.0, "track_front_m")},
          {"track_rear_m", Num(&p.track_rear_m, 0.01, 100.0, "track_rear_m")},
          {"unsprung_front_kg", Num(&p.unsprung_front_kg, 0.1, 1e4, "unsprung_front_kg")},
          {"unsprung_rear_kg", Num(&p.unsprung_rear_kg, 0.1, 1e4, "unsprung_rear_kg")},
          {"spring_front_n_per_m", Num(&p.spring_front_n_per_m, 1.0, 1e8, "spring_front_n_per_m")},
          {"spring_rear_n_per_m", Num(&p.spring_rear_n_per_m, 1.0, 1e8, "spring_rear_n_per_m")},
          {"tyre_n_per_m", Num(&p.tyre_n_per_m, 1.0, 1e9, "tyre_n_per_m")},
          {"motion_ratio", Num(&p.motion_ratio, 0.01, 1.0, "motion_ratio")},
          {"seat_x_m", Num(&p.seat_x_m, -100.0, 100.0, "seat_x_m")},
          {"seat_y_m", Num(&p.seat_y_m, -100.0, 100.0, "seat_y_m")},
          {"substeps", Int(&p.substeps, 1, 10000, "substeps")},
          {"speed_m_s", Num(&s.car.speed_m_s, 0.0, 100.0, "speed_m_s")},
          {"coherence", Num(&s.road_coherence, 0.0, 1.0, "coherence")},
          {"settle_s", Num(&s.ride_settle_s, 0.0, 1e6, "settle_s")},
          {"passive_step_v", Num(&s.passive_step_v, 0.0, 1e3, "passive_step_v")},
          {"pair_step_v", Num(&s.pair_step_v, 0.0, 1e3, "pair_step_v")}};
}

// model = "full-car": [full_car] and [road] (the road's class as the quarter car's); what the
// study cannot run ([excitation], [gpio], faults without [channels]) refused here.
bool ScenarioReader::CheckFullCar() {
  Ctx& c = c_;
  s.full_car = model_ == "full-car";
  if (!s.full_car) {
    if (root_.contains("full_car")) {
      return c.Fail(at("full_car"), "[full_car] needs [plant] model = \"full-car\"");
    }
    return true;
  }
  if (road_class_.size() != 1 || !RoadClassFromChar(road_class_[0], &s.road.road_class)) {
    return c.Fail(at("road.class"), "road class must be one of A .. H");
  }
  TwoTrackRoadParams road;
  road.road = s.road;
  road.correlation = s.road_coherence;
  road.wheelbase_m = s.full.wheelbase_m();
  const char* why = nullptr;
  if (!road.IsValid(&why)) return c.Fail(at("road"), std::string("[road]: ") + why);
  if (!s.full.IsValid(&why)) return c.Fail(at("full_car"), std::string("[full_car]: ") + why);
  s.car.motion_ratio = s.full.motion_ratio;
  s.car.max_volts = s.e_max;
  if (root_.contains("excitation")) {
    return c.Fail(at("excitation"), "a full car is excited by its [road], not [excitation]");
  }
  if (root_.contains("gpio")) return c.Fail(at("gpio"), "a full car has no [gpio] lines");
  if (root_.contains("fault") && !root_.contains("channels")) {
    return c.Fail(at("fault"),
                  "a full car takes faults only over CAN or Modbus with [channels] (`mrd-hil "
                  "study` runs none)");
  }
  if (s.ride_settle_s >= s.duration_s) {
    return c.Fail(at("full_car.settle_s"), "settle_s must be shorter than duration_s");
  }
  const double steps[2] = {s.passive_step_v, s.pair_step_v};
  const char* keys[2] = {"full_car.passive_step_v", "full_car.pair_step_v"};
  for (int i = 0; i < 2; ++i) {
    if (!(steps[i] > 0.0) || s.e_max / steps[i] > (i == 0 ? 10000.0 : 100.0)) {
      return c.Fail(at(keys[i]), std::string(keys[i] + 9) + " must be > 0 and give at most " +
                                     (i == 0 ? "10000" : "100") + " points over 0 .. e_max");
    }
  }
  return true;
}

}  // namespace mrd::hil::scenario_reader
