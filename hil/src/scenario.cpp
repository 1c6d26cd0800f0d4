#include "mrd/hil/scenario.hpp"

#include <toml++/toml.h>

#include <sys/stat.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>

#include "mrd/common/input_file.hpp"
#include "mrd/common/spencer_damper.hpp"
#include "scenario_set.hpp"
#include "plant_params.hpp"
#include "replay_scenario.hpp"

namespace mrd::hil {
namespace {

constexpr const char* kHelp = R"(Scenario keys (TOML; every key optional unless marked):
  name, description        text
  duration_s               plant time to run [s] (default 5)
  e_max                    highest admissible command [V] (2.25); the invariant's bound
  heartbeat_timeout_ms     simulated driver drops the coil to 0 V without a heartbeat (50)
  [plant]       preset = "paper" | "spencer1997", or params = "FILE.toml" (a Spencer
                parameter file as `mrd generate --params` reads and `mrd fit-spencer` writes,
                relative to the scenario); substeps (RK4 steps per period, 20);
                model = "damper" (default: the damper alone on [excitation]) | "quarter-car"
                (the damper between body and wheel of a quarter car on an ISO 8608 road; the
                road is the excitation; ride figures scored next to passive-off and -on)
  [plant.spencer] c0a c0b k0 c1a c1b k1 x0 alpha_a alpha_b gamma beta A n eta: overrides
                of single damper parameters on top of preset or params (damper and quarter car)
  [quarter_car] sprung_mass_kg (300), unsprung_mass_kg (40), spring_n_per_m (20000),
                tyre_n_per_m (180000), motion_ratio (0.7, damper / wheel travel),
                speed_m_s (20), substeps (10), settle_s (2: ride figures scored after it)
  [road]        class = "A" .. "H" ("C"), seed (1), n_min (0.011), n_max (2.83) [cycles/m],
                components (256)
  [excitation]  kind = "periodic" | "csv" | "replay"
                periodic: amplitude_cm, frequency_hz, demand_amplitude_n, demand_frequency_hz,
                          body_amplitude, body_frequency_hz, body_phase_rad
                csv: file (header naming x and v; relative to the scenario file),
                     demand_column (default "f": an `mrd generate` data set's force, reachable
                     by construction)
                replay: file (a measured run with columns x, v, E, f: `mrd import` or `mrd
                     generate`); the plant follows the measured x, v; law "force" tracks f,
                     law "open-loop" commands the measured E; the summary scores the plant's
                     force against the measured f (fit %, RMSE)
  [control]     law = "force" | "passive-off" | "passive-on" | "constant" | "skyhook" |
                "open-loop" (replay only: the firmware passes the measured E through);
                constant_voltage [V]; skyhook_gain [N s/cm]
  [firmware]    max_age_ms (5), recover_periods (5), velocity_limit [cm/s] (250),
                grant_timeout_ms (10000: lockstep, the firmware stops when no grant came
                for this long): written into the generated mrd-firmware config;
                table = "FILE.bin" (the firmware's table, `mrd export`, relative to the
                scenario; --table overrides; default: the compiled-in table)
  [pass]        max_invariant_violations (0), max_error_reachable, max_error_all,
                max_missed_grants, max_detection_to_safe_periods (2), require_recovery (true),
                min_replay_fit (replay: least fit % of plant force vs measured f),
                expect_firmware_exit (e.g. 2 with a corrupt_table fault),
                body_accel_below_passive (quarter car: the controlled run's body acceleration
                RMS below both passive-off and passive-on; false)
  [gpio]        inputs = list of displacement | fault_line; outputs = list of enable |
                heartbeat (routed over GPIO lines instead of CAN; displacement from a
                quadrature encoder the plant drives, velocity differentiated by the firmware);
                counts_per_cm (400), velocity_cutoff_hz (50)
  [[fault]]     kind (required) = drop | delay | corrupt | stall | out_of_range | nan |
                implausible | kill_plant | kill_firmware | corrupt_table | fault_line |
                drive_heartbeat_loss (CANopen profiles: the drive's heartbeat stops);
                at_s (onset), duration_s (0: to the end), delay_periods (delay, 10)
)";

constexpr std::uint64_t kMaxScenarioBytes = 1 << 20;  // [bytes]

struct Ctx {
  const std::string& path;
  std::string* error;
  bool Fail(const toml::node& n, const std::string& why) {  // why may echo input
    const auto& from = n.source().path;  // "--set KEY=VALUE" for an override's node
    *error = from && *from != path ? *from + ": " + Printable(why)
             : Printable(path) + ":" + std::to_string(n.source().begin.line) + ": " + Printable(why);
    return false;
  }
};

using Setter = std::function<bool(const toml::node&, Ctx&)>;

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
template <typename T>
Setter Int(T* out, std::int64_t lo, std::int64_t hi, const char* key) {
  return [=](const toml::node& n, Ctx& c) {
    const auto v = n.value_exact<std::int64_t>();
    if (!v || *v < lo || *v > hi) {
      return c.Fail(n, std::string("'") + key + "' must be an integer in [" + std::to_string(lo) +
                           ", " + std::to_string(hi) + "]");
    }
    *out = static_cast<T>(*v);
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

// A list of names, each one of `allowed` (name -> flag it sets).
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

bool ParseFaultKind(const std::string& s, FaultKind* k) {
  static const std::map<std::string, FaultKind> kinds = {
      {"drop", FaultKind::kDrop},           {"delay", FaultKind::kDelay},
      {"corrupt", FaultKind::kCorrupt},     {"stall", FaultKind::kStall},
      {"out_of_range", FaultKind::kOutOfRange}, {"nan", FaultKind::kNan},
      {"implausible", FaultKind::kImplausible}, {"kill_plant", FaultKind::kKillPlant},
      {"kill_firmware", FaultKind::kKillFirmware}, {"corrupt_table", FaultKind::kCorruptTable},
      {"fault_line", FaultKind::kFaultLine},
      {"drive_heartbeat_loss", FaultKind::kDriveHeartbeatLoss}};
  const auto it = kinds.find(s);
  if (it == kinds.end()) return false;
  *k = it->second;
  return true;
}

std::string Folder(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

}  // namespace

const char* FaultKindName(FaultKind kind) {
  switch (kind) {
    case FaultKind::kDrop: return "drop";
    case FaultKind::kDelay: return "delay";
    case FaultKind::kCorrupt: return "corrupt";
    case FaultKind::kStall: return "stall";
    case FaultKind::kOutOfRange: return "out_of_range";
    case FaultKind::kNan: return "nan";
    case FaultKind::kImplausible: return "implausible";
    case FaultKind::kKillPlant: return "kill_plant";
    case FaultKind::kKillFirmware: return "kill_firmware";
    case FaultKind::kCorruptTable: return "corrupt_table";
    case FaultKind::kFaultLine: return "fault_line";
    case FaultKind::kDriveHeartbeatLoss: return "drive_heartbeat_loss";
  }
  return "?";
}

const char* ScenarioKeysHelp() { return kHelp; }

bool LoadScenario(const std::string& path, Scenario* scenario, std::string* error) {
  return LoadScenario(path, {}, scenario, error);
}

bool LoadScenario(const std::string& path, const std::vector<std::string>& sets,
                  Scenario* scenario, std::string* error) {
  Ctx c{path, error};
  try {
    // A regular file of at most kMaxScenarioBytes: a directory, FIFO or device is refused.
    std::string text;
    if (!ReadInputFile(path, kMaxScenarioBytes, &text, error)) return false;
    toml::table root = toml::parse(text, path);
    if (!ApplyScenarioSets(sets, &root, error)) return false;
    Scenario s;
    s.path = path;
    double hb_ms = s.heartbeat_timeout_s * 1e3;
    std::string excitation = "periodic";
    PlantExcitation& p = s.periodic;
    int pass_max_viol = 0;
    double max_missed = -1.0, err_reach = -1.0, err_all = -1.0, replay_fit = -HUGE_VAL;
    int expect_exit = -1;
    std::string model = "damper", road_class = "C";
    const toml::table* spencer = nullptr;  // [plant.spencer] overrides
    const std::map<std::string, Setter> plant = {
        {"preset", Str(&s.preset, "preset")},
        {"params", Str(&s.params_file, "params")},
        {"spencer", [&spencer](const toml::node& n, Ctx& cx) {
           spencer = n.as_table();
           return spencer != nullptr || cx.Fail(n, "[plant.spencer] must be a table");
         }},
        {"substeps", Int(&s.substeps, 1, 1000, "substeps")},
        {"model", Str(&model, "model")}};
    QuarterCarParams& car = s.car;
    const std::map<std::string, Setter> quarter_car = {
        {"sprung_mass_kg", Num(&car.sprung_mass_kg, 1.0, 1e5, "sprung_mass_kg")},
        {"unsprung_mass_kg", Num(&car.unsprung_mass_kg, 0.1, 1e4, "unsprung_mass_kg")},
        {"spring_n_per_m", Num(&car.spring_n_per_m, 1.0, 1e8, "spring_n_per_m")},
        {"tyre_n_per_m", Num(&car.tyre_n_per_m, 1.0, 1e9, "tyre_n_per_m")},
        {"motion_ratio", Num(&car.motion_ratio, 0.01, 1.0, "motion_ratio")},
        {"speed_m_s", Num(&car.speed_m_s, 0.0, 100.0, "speed_m_s")},
        {"substeps", Int(&car.substeps, 1, 10000, "substeps")},
        {"settle_s", Num(&s.ride_settle_s, 0.0, 1e6, "settle_s")}};
    RoadParams& road = s.road;
    const std::map<std::string, Setter> road_keys = {
        {"class", Str(&road_class, "class")},
        {"seed", Int(&road.seed, 0, std::numeric_limits<std::int64_t>::max(), "seed")},
        {"n_min", Num(&road.n_min, 1e-6, 100.0, "n_min")},
        {"n_max", Num(&road.n_max, 1e-6, 100.0, "n_max")},
        {"components", Int(&road.components, 1, 65536, "components")}};
    const std::map<std::string, Setter> exc = {
        {"kind", Str(&excitation, "kind")},
        {"amplitude_cm", Num(&p.amplitude_cm, 0.0, 30.0, "amplitude_cm")},
        {"frequency_hz", Num(&p.frequency_hz, 0.0, 100.0, "frequency_hz")},
        {"demand_amplitude_n", Num(&p.demand_amplitude_n, 0.0, 15000.0, "demand_amplitude_n")},
        {"demand_frequency_hz", Num(&p.demand_frequency_hz, 0.0, 100.0, "demand_frequency_hz")},
        {"body_amplitude", Num(&p.body_amplitude, 0.0, 300.0, "body_amplitude")},
        {"body_frequency_hz", Num(&p.body_frequency_hz, 0.0, 100.0, "body_frequency_hz")},
        {"body_phase_rad", Num(&p.body_phase_rad, -10.0, 10.0, "body_phase_rad")},
        {"file", Str(&s.csv_file, "file")},
        {"demand_column", Str(&s.demand_column, "demand_column")}};
    const std::map<std::string, Setter> control = {
        {"law", Str(&s.law, "law")},
        {"constant_voltage", Num(&s.constant_voltage, 0.0, 24.0, "constant_voltage")},
        {"skyhook_gain", Num(&s.skyhook_gain, 0.0, 1e6, "skyhook_gain")}};
    const std::map<std::string, Setter> firmware = {
        {"max_age_ms", Num(&s.max_age_ms, 0.01, 1e4, "max_age_ms")},
        {"recover_periods", Int(&s.recover_periods, 1, 1000000, "recover_periods")},
        {"velocity_limit", Num(&s.velocity_limit, 0.0, 1e6, "velocity_limit")},
        {"grant_timeout_ms", Num(&s.grant_timeout_ms, 100.0, 3.6e6, "grant_timeout_ms")},
        {"table", Str(&s.table_file, "table")}};
    const std::map<std::string, Setter> pass = {
        {"max_invariant_violations", Int(&pass_max_viol, 0, 1000000000, "max_invariant_violations")},
        {"max_error_reachable", Num(&err_reach, 0.0, 1e6, "max_error_reachable")},
        {"max_error_all", Num(&err_all, 0.0, 1e6, "max_error_all")},
        {"min_replay_fit", Num(&replay_fit, -1e9, 100.0, "min_replay_fit")},
        {"max_missed_grants", Num(&max_missed, 0.0, 1e12, "max_missed_grants")},
        {"max_detection_to_safe_periods",
         Int(&s.max_detection_to_safe_periods, 0, 1000000, "max_detection_to_safe_periods")},
        {"require_recovery", Flag(&s.require_recovery, "require_recovery")},
        {"expect_firmware_exit", Int(&expect_exit, 0, 255, "expect_firmware_exit")},
        {"body_accel_below_passive",
         Flag(&s.body_accel_below_passive, "body_accel_below_passive")}};
    ScenarioGpio& g = s.gpio;
    const std::map<std::string, Setter> gpio = {
        {"inputs", Names({{"displacement", &g.displacement}, {"fault_line", &g.fault_line}},
                         "inputs")},
        {"outputs", Names({{"enable", &g.enable}, {"heartbeat", &g.heartbeat}}, "outputs")},
        {"counts_per_cm", Num(&g.counts_per_cm, 1e-3, 1e9, "counts_per_cm")},
        {"velocity_cutoff_hz", Num(&g.velocity_cutoff_hz, 1e-3, 1e5, "velocity_cutoff_hz")}};
    for (const auto& [k, v] : root) {
      const std::string key(k.str());
      bool ok = true;
      if (key == "name") {
        ok = Str(&s.name, "name")(v, c);
      } else if (key == "description") {
        ok = Str(&s.description, "description")(v, c);
      } else if (key == "duration_s") {
        ok = Num(&s.duration_s, 0.001, 1e6, "duration_s")(v, c);
      } else if (key == "e_max") {
        ok = Num(&s.e_max, 0.0, 24.0, "e_max")(v, c);
      } else if (key == "heartbeat_timeout_ms") {
        ok = Num(&hb_ms, 1.0, 1e4, "heartbeat_timeout_ms")(v, c);
      } else if (key == "plant" || key == "excitation" || key == "control" || key == "firmware" ||
                 key == "pass" || key == "quarter_car" || key == "road" || key == "gpio") {
        const toml::table* t = v.as_table();
        if (t == nullptr) return c.Fail(v, "[" + key + "] must be a table");
        const auto& keys = key == "plant" ? plant : key == "excitation" ? exc
                         : key == "control" ? control : key == "firmware" ? firmware
                         : key == "quarter_car" ? quarter_car : key == "road" ? road_keys
                         : key == "gpio" ? gpio : pass;
        ok = ApplyTable(*t, keys, " in [" + key + "]", c);
      } else if (key == "fault") {
        const toml::array* a = v.as_array();
        if (a == nullptr) return c.Fail(v, "'fault' must be an array of tables ([[fault]])");
        for (const toml::node& e : *a) {
          const toml::table* t = e.as_table();
          if (t == nullptr) return c.Fail(e, "each [[fault]] must be a table");
          Fault f;
          f.line = static_cast<int>(e.source().begin.line);
          std::string kind;
          const std::map<std::string, Setter> fk = {
              {"kind", Str(&kind, "kind")},
              {"at_s", Num(&f.at_s, 0.0, 1e6, "at_s")},
              {"duration_s", Num(&f.duration_s, 0.0, 1e6, "duration_s")},
              {"delay_periods", Int(&f.delay_periods, 1, 100000, "delay_periods")}};
          if (!ApplyTable(*t, fk, " in [[fault]]", c)) return false;
          if (kind.empty()) return c.Fail(e, "[[fault]] needs 'kind'");
          if (!ParseFaultKind(kind, &f.kind)) {
            return c.Fail(e, "unknown fault kind '" + kind + "' (see mrd-hil --help)");
          }
          s.faults.push_back(f);
        }
      } else {
        return c.Fail(v, "unknown key '" + key + "'");
      }
      if (!ok) return false;
    }
    s.heartbeat_timeout_s = hb_ms * 1e-3;
    if (!s.params_file.empty() && root.at_path("plant.preset").node() != nullptr) {
      return c.Fail(*root.at_path("plant.params").node(),
                    "[plant] params and preset exclude each other (the file may name a preset)");
    }
    if (!s.params_file.empty() && s.params_file[0] != '/') {
      s.params_file = Folder(path) + "/" + s.params_file;
    }
    if (!ResolvePlantDamper(path, root, spencer, &s, error)) return false;
    const auto at = [&](const char* key) -> const toml::node& {
      const toml::node* n = root.at_path(key).node();
      return n != nullptr ? *n : static_cast<const toml::node&>(root);
    };
    if (!s.table_file.empty()) {
      if (s.table_file[0] != '/') s.table_file = Folder(path) + "/" + s.table_file;
      struct stat st {};
      if (stat(s.table_file.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
        return c.Fail(at("firmware.table"), "[firmware] table '" + s.table_file +
                                                "': not a readable file");
      }
    }
    if (model != "damper" && model != "quarter-car") {
      return c.Fail(at("plant.model"), "plant model must be \"damper\" or \"quarter-car\"");
    }
    s.quarter_car = model == "quarter-car";
    if (!s.quarter_car && (root.contains("quarter_car") || root.contains("road"))) {
      return c.Fail(root.contains("road") ? at("road") : at("quarter_car"),
                    "[quarter_car] and [road] need [plant] model = \"quarter-car\"");
    }
    if (s.quarter_car) {
      if (road_class.size() != 1 || !RoadClassFromChar(road_class[0], &road.road_class)) {
        return c.Fail(at("road.class"), "road class must be one of A .. H");
      }
      const char* why = nullptr;
      if (!road.IsValid(&why)) return c.Fail(at("road"), std::string("[road]: ") + why);
      car.max_volts = s.e_max;
      if (!car.IsValid(&why)) return c.Fail(at("quarter_car"), std::string("[quarter_car]: ") + why);
      if (root.contains("excitation")) {
        return c.Fail(at("excitation"), "a quarter car is excited by its [road], not [excitation]");
      }
      if (s.ride_settle_s >= s.duration_s) {
        return c.Fail(at("quarter_car.settle_s"), "settle_s must be shorter than duration_s");
      }
    } else if (s.body_accel_below_passive) {
      return c.Fail(at("pass.body_accel_below_passive"),
                    "body_accel_below_passive needs [plant] model = \"quarter-car\"");
    }
    if (excitation == "periodic") {
      s.excitation = ExcitationKind::kPeriodic;
    } else if (excitation == "csv") {
      s.excitation = ExcitationKind::kCsv;
      if (s.csv_file.empty()) {
        return c.Fail(*root.at_path("excitation.kind").node(), "kind = \"csv\" needs 'file'");
      }
      if (s.csv_file[0] != '/') s.csv_file = Folder(path) + "/" + s.csv_file;
    } else if (excitation == "replay") {
      if (!CheckReplay(path, root, &s, error)) return false;  // replay.cpp
    } else {
      return c.Fail(*root.at_path("excitation.kind").node(),
                    "excitation kind must be \"periodic\", \"csv\" or \"replay\"");
    }
    if (s.law != "force" && s.law != "passive-off" && s.law != "passive-on" &&
        s.law != "constant" && s.law != "skyhook" && s.law != "open-loop") {
      return c.Fail(*root.at_path("control.law").node(),
                    "law must be force | passive-off | passive-on | constant | skyhook | "
                    "open-loop");
    }
    if (s.law == "open-loop" && s.excitation != ExcitationKind::kReplay) {
      return c.Fail(*root.at_path("control.law").node(),
                    "law \"open-loop\" needs [excitation] kind = \"replay\" (the measured E)");
    }
    if (s.law == "constant" && s.constant_voltage > s.e_max) {
      return c.Fail(*root.at_path("control.constant_voltage").node(),
                    "constant_voltage above e_max");
    }
    s.max_invariant_violations = static_cast<std::uint64_t>(pass_max_viol);
    if (err_reach >= 0.0) s.max_error_reachable = err_reach;
    if (err_all >= 0.0) s.max_error_all = err_all;
    if (replay_fit > -HUGE_VAL) {
      if (s.excitation != ExcitationKind::kReplay) {
        return c.Fail(*root.at_path("pass.min_replay_fit").node(),
                      "min_replay_fit needs [excitation] kind = \"replay\"");
      }
      s.min_replay_fit = replay_fit;
    }
    if (s.law == "open-loop" && (s.max_error_reachable || s.max_error_all)) {
      return c.Fail(root.contains("pass") ? *root.get("pass") : static_cast<const toml::node&>(root),
                    "law \"open-loop\" tracks no force: score it with min_replay_fit, not "
                    "max_error_*");
    }
    if (max_missed >= 0.0) s.max_missed_grants = static_cast<std::uint64_t>(max_missed);
    if (expect_exit >= 0) s.expect_firmware_exit = expect_exit;
    for (const Fault& f : s.faults) {
      if (f.kind == FaultKind::kFaultLine && !s.gpio.fault_line) {
        *error = path + ":" + std::to_string(f.line) +
                 ": a fault_line fault needs [gpio] inputs = [..., \"fault_line\"]";
        return false;
      }
      if (f.kind != FaultKind::kCorruptTable && f.at_s >= s.duration_s) {
        *error = path + ":" + std::to_string(f.line) + ": fault at_s " + std::to_string(f.at_s) +
                 " is not before the end (duration_s " + std::to_string(s.duration_s) + ")";
        return false;
      }
    }
    *scenario = std::move(s);
    return true;
  } catch (const toml::parse_error& e) {
    *error = Printable(path) + ":" + std::to_string(e.source().begin.line) + ": " +
             Printable(e.description());
    return false;
  } catch (const std::exception& e) {
    *error = Printable(path) + ": " + e.what();
    return false;
  }
}

}  // namespace mrd::hil
