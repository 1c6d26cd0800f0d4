// Each [section]'s keys, their types and ranges (scenario_reader.hpp).
#include <cmath>
#include <limits>

#include "scenario_reader.hpp"

namespace mrd::hil::scenario_reader {

Setter Num(double* out, double lo, double hi, const char* key) {
  return [=](const toml::node& n, Ctx& c) {
    const auto v = n.value<double>();
    if (!v || !std::isfinite(*v) || *v < lo || *v > hi) {
      return c.Fail(n, std::string("'") + key + "' must be a number in [" + std::to_string(lo) +
                           ", " + std::to_string(hi) + "]");
    }
    *out = *v;
    return true;
  };
}
Setter Str(std::string* out, const char* key) {
  return [=](const toml::node& n, Ctx& c) {
    const auto v = n.value_exact<std::string>();
    if (!v || v->empty()) return c.Fail(n, std::string("'") + key + "' must be a non-empty string");
    *out = *v;
    return true;
  };
}
Setter Flag(bool* out, const char* key) {
  return [=](const toml::node& n, Ctx& c) {
    const auto v = n.value_exact<bool>();
    if (!v) return c.Fail(n, std::string("'") + key + "' must be true or false");
    *out = *v;
    return true;
  };
}

Setter Names(const std::map<std::string, bool*>& allowed, const char* key) {
  return [=](const toml::node& n, Ctx& c) {
    const toml::array* a = n.as_array();
    std::string names;
    for (const auto& [name, flag] : allowed) names += (names.empty() ? "" : ", ") + name;
    if (a == nullptr) return c.Fail(n, std::string("'") + key + "' must be a list of: " + names);
    for (const toml::node& e : *a) {
      const auto v = e.value_exact<std::string>();
      const auto it = v ? allowed.find(*v) : allowed.end();
      if (it == allowed.end()) {
        return c.Fail(e, std::string("'") + key + "' accepts: " + names);
      }
      *it->second = true;
    }
    return true;
  };
}

bool ApplyTable(const toml::table& t, const std::map<std::string, Setter>& keys,
                const std::string& where, Ctx& c) {
  for (const auto& [k, v] : t) {
    const auto it = keys.find(std::string(k.str()));
    if (it == keys.end()) return c.Fail(v, "unknown key '" + std::string(k.str()) + "'" + where);
    if (!it->second(v, c)) return false;
  }
  return true;
}

std::map<std::string, Setter> ScenarioReader::PlantKeys() {
  return {{"preset", Str(&s.preset, "preset")},
          {"params", Str(&s.params_file, "params")},
          {"spencer",
           [this](const toml::node& n, Ctx& cx) {
             spencer_ = n.as_table();
             return spencer_ != nullptr || cx.Fail(n, "[plant.spencer] must be a table");
           }},
          {"substeps", Int(&s.substeps, 1, 1000, "substeps")},
          {"model", Str(&model_, "model")},
          {"file", Str(&model_file_, "file")},
          {"iteration", Int(&model_iteration_, 0, 1000000, "iteration")},
          {"envelope_margin", Num(&envelope_margin_, 0.0, 100.0, "envelope_margin")}};
}

std::map<std::string, Setter> ScenarioReader::StructureKeys() {
  return {{"record", Str(&record_file_, "record")},
          {"time_scale", Num(&structure_->time_scale, 0.01, 1000.0, "time_scale")},
          {"amplitude", Num(&structure_->amplitude, 0.0, 100.0, "amplitude")}};
}

std::map<std::string, Setter> ScenarioReader::QuarterCarKeys() {
  QuarterCarParams& car = s.car;
  return {{"sprung_mass_kg", Num(&car.sprung_mass_kg, 1.0, 1e5, "sprung_mass_kg")},
          {"unsprung_mass_kg", Num(&car.unsprung_mass_kg, 0.1, 1e4, "unsprung_mass_kg")},
          {"spring_n_per_m", Num(&car.spring_n_per_m, 1.0, 1e8, "spring_n_per_m")},
          {"tyre_n_per_m", Num(&car.tyre_n_per_m, 1.0, 1e9, "tyre_n_per_m")},
          {"motion_ratio", Num(&car.motion_ratio, 0.01, 1.0, "motion_ratio")},
          {"speed_m_s", Num(&car.speed_m_s, 0.0, 100.0, "speed_m_s")},
          {"substeps", Int(&car.substeps, 1, 10000, "substeps")},
          {"settle_s", Num(&s.ride_settle_s, 0.0, 1e6, "settle_s")},
          {"passive_step_v", Num(&s.passive_step_v, 0.0, 1e3, "passive_step_v")}};
}

std::map<std::string, Setter> ScenarioReader::RoadKeys() {
  RoadParams& road = s.road;
  return {{"class", Str(&road_class_, "class")},
          {"seed", Int(&road.seed, 0, std::numeric_limits<std::int64_t>::max(), "seed")},
          {"n_min", Num(&road.n_min, 1e-6, 100.0, "n_min")},
          {"n_max", Num(&road.n_max, 1e-6, 100.0, "n_max")},
          {"components", Int(&road.components, 1, 65536, "components")}};
}

std::map<std::string, Setter> ScenarioReader::ExcitationKeys() {
  PlantExcitation& p = s.periodic;
  return {{"kind", Str(&excitation_, "kind")},
          {"amplitude_cm", Num(&p.amplitude_cm, 0.0, 30.0, "amplitude_cm")},
          {"frequency_hz", Num(&p.frequency_hz, 0.0, 100.0, "frequency_hz")},
          {"demand_amplitude_n", Num(&p.demand_amplitude_n, 0.0, 15000.0, "demand_amplitude_n")},
          {"demand_frequency_hz", Num(&p.demand_frequency_hz, 0.0, 100.0, "demand_frequency_hz")},
          {"body_amplitude", Num(&p.body_amplitude, 0.0, 300.0, "body_amplitude")},
          {"body_frequency_hz", Num(&p.body_frequency_hz, 0.0, 100.0, "body_frequency_hz")},
          {"body_phase_rad", Num(&p.body_phase_rad, -10.0, 10.0, "body_phase_rad")},
          {"file", Str(&s.csv_file, "file")},
          {"demand_column", Str(&s.demand_column, "demand_column")},
          {"profile", Str(&s.profile, "profile")},
          {"seed", Int(&s.profile_seed, 0, std::numeric_limits<std::int64_t>::max(), "seed")}};
}

std::map<std::string, Setter> ScenarioReader::ControlKeys() {
  return {{"law", Str(&s.law, "law")},
          {"constant_voltage", Num(&s.constant_voltage, 0.0, 24.0, "constant_voltage")},
          {"skyhook_gain", Num(&s.skyhook_gain, 0.0, 1e6, "skyhook_gain")},
          {"groundhook_gain", Num(&s.groundhook_gain, 0.0, 1e6, "groundhook_gain")},
          {"hybrid_gain", Num(&s.hybrid_gain, 0.0, 1e6, "hybrid_gain")},
          {"hybrid_alpha", Num(&s.hybrid_alpha, 0.0, 1.0, "hybrid_alpha")},
          {"sh_add_alpha", Num(&s.sh_add_alpha, 1e-3, 1e4, "sh_add_alpha")},
          {"gains", Str(&s.clipped_gains, "gains")},
          {"clipped_command", Str(&s.clipped_command, "clipped_command")}};
}

std::map<std::string, Setter> ScenarioReader::FirmwareKeys() {
  return {{"max_age_ms", Num(&s.max_age_ms, 0.01, 1e4, "max_age_ms")},
          {"recover_periods", Int(&s.recover_periods, 1, 1000000, "recover_periods")},
          {"velocity_limit", Num(&s.velocity_limit, 0.0, 1e6, "velocity_limit")},
          {"grant_timeout_ms", Num(&s.grant_timeout_ms, 100.0, 3.6e6, "grant_timeout_ms")},
          {"table", Str(&s.table_file, "table")}};
}

std::map<std::string, Setter> ScenarioReader::PassKeys() {
  return {
      {"max_invariant_violations", Int(&pass_max_viol_, 0, 1000000000, "max_invariant_violations")},
      {"max_error_reachable", Num(&err_reach_, 0.0, 1e6, "max_error_reachable")},
      {"max_error_all", Num(&err_all_, 0.0, 1e6, "max_error_all")},
      {"min_reachable_share", Num(&s.min_reachable_share, 0.0, 1.0, "min_reachable_share")},
      {"min_replay_fit", Num(&replay_fit_, -1e9, 100.0, "min_replay_fit")},
      {"max_missed_grants", Num(&max_missed_, 0.0, 1e12, "max_missed_grants")},
      {"max_detection_to_safe_periods",
       Int(&s.max_detection_to_safe_periods, 0, 1000000, "max_detection_to_safe_periods")},
      {"require_recovery", Flag(&s.require_recovery, "require_recovery")},
      {"expect_firmware_exit", Int(&expect_exit_, 0, 255, "expect_firmware_exit")},
      {"body_accel_below_passive", Flag(&s.body_accel_below_passive, "body_accel_below_passive")},
      {"tyre_load_below_passive_off",
       Flag(&s.tyre_load_below_passive_off, "tyre_load_below_passive_off")},
      {"peak_drift_below_passive_on",
       Flag(&s.peak_drift_below_passive_on, "peak_drift_below_passive_on")},
      {"peak_accel_below_passive_on",
       Flag(&s.peak_accel_below_passive_on, "peak_accel_below_passive_on")},
      {"max_peak_force_n", Num(&max_peak_force_, 0.0, 1e7, "max_peak_force_n")}};
}

std::map<std::string, Setter> ScenarioReader::GpioKeys() {
  ScenarioGpio& g = s.gpio;
  return {{"inputs",
           Names({{"displacement", &g.displacement}, {"fault_line", &g.fault_line}}, "inputs")},
          {"outputs", Names({{"enable", &g.enable}, {"heartbeat", &g.heartbeat}}, "outputs")},
          {"counts_per_cm", Num(&g.counts_per_cm, 1e-3, 1e9, "counts_per_cm")},
          {"velocity_cutoff_hz", Num(&g.velocity_cutoff_hz, 1e-3, 1e5, "velocity_cutoff_hz")}};
}

}  // namespace mrd::hil::scenario_reader
