// `mrd-hil study` on a full car (full_car_study.hpp).
#include "full_car_study.hpp"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "full_car_law.hpp"
#include "mrd/common/write_atomically.hpp"
#include "mrd/hil/plants/full_car_ride.hpp"
#include "report.hpp"
#include "study_support.hpp"
#include "table_check.hpp"

namespace mrd::hil {
namespace {

using study::Bad;
using study::Num;
using study::Signed;

constexpr double kPeriod = 1e-3;  // [s]
constexpr const char* kDefaultLaws = "skyhook,groundhook,sh-add,modal-skyhook";

struct LawResult {
  FullCarLawRun run;
  std::optional<std::size_t> at_holding;  // into the case's passive points (both grids)
  std::optional<double> improvement;      // Wk comfort vs that point [%]
};

struct Case {
  char road_class = 'C';
  double speed = 20.0;
  double motion_ratio = 0.7;
  std::vector<FullCarRidePoint> uniform;  // all four at one voltage
  std::vector<FullCarRidePoint> pairs;    // front / rear apart
  std::vector<LawResult> laws;
  std::vector<FullCarRidePoint> Passive() const {
    std::vector<FullCarRidePoint> all = uniform;
    all.insert(all.end(), pairs.begin(), pairs.end());
    return all;
  }
};

struct Inputs : study::BaseInputs {
  std::vector<double> pair_volts;
  std::vector<char> classes;
  std::vector<double> speeds, ratios;
  std::vector<FullCarLawSpec> laws;
};

int ParseLaws(const StudyOptions& o, Inputs* in) {
  const Scenario& b = in->base;
  std::ostringstream safety;
  safety << "\n[safety]\nmax_age_ms = " << b.max_age_ms
         << "\nrecover_periods = " << b.recover_periods << "\nvelocity_limit = " << b.velocity_limit
         << "\n";
  const std::string laws = o.laws_given ? o.laws : kDefaultLaws;
  for (const std::string& spec : study::Split(laws)) {
    FullCarLawSpec law;
    std::string error;
    const std::string sections = spec.find("safety.") == std::string::npos ? safety.str() : "";
    if (!MakeFullCarLaw(spec, b.skyhook_gain, b.e_max, sections, &law, &error) ||
        !CheckFirmwareLaw(law.law, in->table, &error)) {
      return Bad(error);
    }
    for (const FullCarLawSpec& k : in->laws) {
      if (k.law.spec == spec) return Bad("--laws '" + laws + "': names " + spec + " twice");
    }
    in->laws.push_back(law);
  }
  if (in->laws.empty()) return Bad("--laws: no law given");
  return 0;
}

int ParseInputs(const StudyOptions& o, Inputs* in) {
  Scenario& base = in->base;
  std::string error;
  if (const int rc = study::LoadBaseInputs(o, in); rc != 0) return rc;
  if (!GridVoltages(0.0, base.e_max, base.pair_step_v, &in->pair_volts, &error)) {
    return Bad(base.path + ": pair_step_v: " + error);
  }
  if (const int rc = study::ParseClassesAndSpeeds(o, &in->classes, &in->speeds); rc != 0) return rc;
  if (o.motion_ratios.empty()) {
    in->ratios.push_back(base.full.motion_ratio);
  } else if (const int rc = study::ParseNumbers(
                 "--motion-ratios", o.motion_ratios, [](double x) { return x >= 0.01 && x <= 1.0; },
                 "a motion ratio in [0.01, 1]", &in->ratios);
             rc != 0) {
    return rc;
  }
  return ParseLaws(o, in);
}

FullCarPlantParams PlantOf(const Scenario& s, const Case& c) {
  FullCarPlantParams p;
  p.damper = s.damper;
  p.damper_substeps = s.substeps;
  p.car = s.full;
  p.car.motion_ratio = c.motion_ratio;
  p.road.road = s.road;
  RoadClassFromChar(c.road_class, &p.road.road.road_class);
  p.road.correlation = s.road_coherence;
  p.speed_m_s = c.speed;
  p.max_volts = s.e_max;
  return p;
}

// The passive grids and each law of one case, with progress on stderr.
bool RunCase(const Inputs& in, std::size_t index, std::size_t n, Case* c, std::string* error) {
  const Scenario& s = in.base;
  FullCarPlant plant(PlantOf(s, *c), kPeriod);
  std::vector<std::pair<double, double>> uniform, pairs;
  for (const double v : in.volts) uniform.emplace_back(v, v);
  for (const double f : in.pair_volts) {
    for (const double r : in.pair_volts) pairs.emplace_back(f, r);
  }
  std::fprintf(stderr, "[%zu/%zu] class %c, %g m/s, motion ratio %g: passive grids (%zu + %zu)\n",
               index, n, c->road_class, c->speed, c->motion_ratio, uniform.size(), pairs.size());
  c->uniform = RunFullCarGrid(&plant, s.duration_s, s.ride_settle_s, uniform);
  c->pairs = RunFullCarGrid(&plant, s.duration_s, s.ride_settle_s, pairs);
  const std::vector<FullCarRidePoint> passive = c->Passive();
  for (const FullCarLawSpec& law : in.laws) {
    LawResult r;
    if (!RunFullCarLaw(law, in.table, &plant, s.duration_s, s.ride_settle_s, &r.run, error)) {
      return false;
    }
    r.at_holding = BestFullCarAtHolding(passive, r.run.ride.worst_tyre_load_rms_n(),
                                        FullCarMetric::kBodyAccelWk);
    if (r.at_holding) {
      const double best = passive[*r.at_holding].body_accel_wk_rms;
      r.improvement = best > 0.0 ? 100.0 * (best - r.run.ride.body_accel_wk_rms) / best : 0.0;
    }
    std::fprintf(stderr, "[%zu/%zu]   %s: Wk %.4f m/s^2, worst tyre load RMS %.1f N, %s\n", index,
                 n, law.law.spec.c_str(), r.run.ride.body_accel_wk_rms,
                 r.run.ride.worst_tyre_load_rms_n(),
                 r.improvement ? (Signed(*r.improvement) + " vs the best passive").c_str()
                               : "no passive setting with a tyre load this low");
    c->laws.push_back(r);
  }
  return true;
}

std::string Volts(const FullCarRidePoint& p) {
  return p.volts_front == p.volts_rear
             ? Num(p.volts_front, 3) + " V"
             : Num(p.volts_front, 3) + " / " + Num(p.volts_rear, 3) + " V";
}

// "Wk, pitch, roll, worst tyre (volts)" of one run.
std::string Figures(const FullCarRidePoint& p, bool volts) {
  return Num(p.body_accel_wk_rms) + ", " + Num(p.pitch_rate_rms) + ", " + Num(p.roll_rate_rms) +
         ", " + Num(p.worst_tyre_load_rms_n()) + (volts ? " (" + Volts(p) + ")" : "");
}

std::string Table(const std::vector<Case>& cases, const std::vector<FullCarLawSpec>& laws) {
  std::ostringstream o;
  o << "Figures: Wk body acc at the CG [m/s^2], pitch rate, roll rate [rad/s], worst wheel's "
       "tyre load [N] (RMS)\n\n| class | speed [m/s] | motion ratio | passive-off | best passive, "
       "all four (Wk) | best passive, front / rear (Wk)";
  for (const FullCarLawSpec& l : laws) {
    o << " | " << l.law.spec << " | " << l.law.spec << ": Wk vs best passive at no-worse tyre load";
  }
  o << " |\n|---|---|---|---|---|---";
  for (std::size_t i = 0; i < laws.size(); ++i) o << "|---|---";
  o << "|\n";
  for (const Case& c : cases) {
    const auto best = [](const std::vector<FullCarRidePoint>& g) {
      return g[BestFullCarPoint(g, FullCarMetric::kBodyAccelWk)];
    };
    o << "| " << c.road_class << " | " << Num(c.speed) << " | " << Num(c.motion_ratio) << " | "
      << Figures(c.uniform[0], false) << " | " << Figures(best(c.uniform), true) << " | "
      << Figures(best(c.pairs), true);
    const std::vector<FullCarRidePoint> passive = c.Passive();
    for (const LawResult& l : c.laws) {
      o << " | " << Figures(l.run.ride, false) << " | ";
      if (l.improvement) {
        o << "**" << Signed(*l.improvement) << "** (vs "
          << Num(passive[*l.at_holding].body_accel_wk_rms) << " at "
          << Volts(passive[*l.at_holding]) << ")";
      } else {
        o << "none (tyre load below every passive setting)";
      }
    }
    o << " |\n";
  }
  return o.str();
}

nlohmann::json PointJson(const FullCarRidePoint& p) {
  return {{"volts_front", p.volts_front},
          {"volts_rear", p.volts_rear},
          {"body_accel_rms", p.body_accel_rms},
          {"body_accel_wk_rms", p.body_accel_wk_rms},
          {"pitch_rate_rms", p.pitch_rate_rms},
          {"roll_rate_rms", p.roll_rate_rms},
          {"tyre_load_rms_n", p.tyre_load_rms_n},
          {"lift_off", p.lift_off},
          {"samples", p.samples}};
}

nlohmann::json Json(const Inputs& in, const std::vector<Case>& cases) {
  const Scenario& s = in.base;
  nlohmann::json j;
  j["scenario"] = s.name;
  j["plant_kind"] = "full-car";
  j["duration_s"] = s.duration_s;
  j["settle_s"] = s.ride_settle_s;
  j["road_seed"] = s.road.seed;
  j["road_coherence"] = s.road_coherence;
  j["passive_step_v"] = in.volts.size() > 1 ? in.volts[1] - in.volts[0] : 0.0;
  j["pair_step_v"] = s.pair_step_v;
  j["table"] = in.table_label;
  j["plant"] = in.plant_label;
  j["corners"] = {"front-left", "front-right", "rear-left", "rear-right"};
  j["laws"] = nlohmann::json::array();
  for (const FullCarLawSpec& l : in.laws) j["laws"].push_back(l.law.spec);
  j["cases"] = nlohmann::json::array();
  for (const Case& c : cases) {
    nlohmann::json jc = {{"class", std::string(1, c.road_class)},
                         {"speed_m_s", c.speed},
                         {"motion_ratio", c.motion_ratio},
                         {"passive_off", PointJson(c.uniform[0])}};
    jc["best_passive_uniform"] =
        PointJson(c.uniform[BestFullCarPoint(c.uniform, FullCarMetric::kBodyAccelWk)]);
    jc["best_passive_front_rear"] =
        PointJson(c.pairs[BestFullCarPoint(c.pairs, FullCarMetric::kBodyAccelWk)]);
    for (const char* key : {"uniform", "front_rear"}) {
      jc["grid_" + std::string(key)] = nlohmann::json::array();
      for (const FullCarRidePoint& p : key[0] == 'u' ? c.uniform : c.pairs) {
        jc["grid_" + std::string(key)].push_back(PointJson(p));
      }
    }
    const std::vector<FullCarRidePoint> passive = c.Passive();
    jc["laws"] = nlohmann::json::array();
    for (std::size_t i = 0; i < c.laws.size(); ++i) {
      const LawResult& l = c.laws[i];
      nlohmann::json jl = {{"law", in.laws[i].law.spec},
                           {"ride", PointJson(l.run.ride)},
                           {"violations", l.run.violations},
                           {"safe_periods", l.run.safe_periods}};
      jl["wk_comfort_at_equal_road_holding"] =
          l.improvement ? nlohmann::json{{"passive", PointJson(passive[*l.at_holding])},
                                         {"improvement_percent", *l.improvement}}
                        : nlohmann::json(nullptr);
      jc["laws"].push_back(jl);
    }
    j["cases"].push_back(jc);
  }
  return j;
}

std::string CsvRow(const std::string& kind, const FullCarRidePoint& p) {
  std::ostringstream o;
  o.precision(9);
  o << kind << ',' << p.volts_front << ',' << p.volts_rear << ',' << p.body_accel_rms << ','
    << p.body_accel_wk_rms << ',' << p.pitch_rate_rms << ',' << p.roll_rate_rms;
  for (const double t : p.tyre_load_rms_n) o << ',' << t;
  o << ',' << p.lift_off;
  return o.str();
}

// One row per run: the passive grids' and the laws'.
std::string Csv(const Inputs& in, const std::vector<Case>& cases) {
  std::ostringstream o;
  o.precision(9);
  o << "class,speed_m_s,motion_ratio,run,volts_front,volts_rear,body_accel_rms,"
       "body_accel_wk_rms,pitch_rate_rms,roll_rate_rms,tyre_load_rms_fl_n,tyre_load_rms_fr_n,"
       "tyre_load_rms_rl_n,tyre_load_rms_rr_n,lift_off,violations,"
       "wk_improvement_vs_best_passive_percent,table,plant\n";
  const std::string tail =
      ',' + study::CsvCell(in.table_label) + ',' + study::CsvCell(in.plant_label) + '\n';
  for (const Case& c : cases) {
    std::ostringstream head;
    head.precision(9);
    head << c.road_class << ',' << c.speed << ',' << c.motion_ratio << ',';
    for (const FullCarRidePoint& p : c.uniform)
      o << head.str() << CsvRow("passive", p) << ",," << tail;
    for (const FullCarRidePoint& p : c.pairs)
      o << head.str() << CsvRow("passive-front-rear", p) << ",," << tail;
    for (std::size_t i = 0; i < c.laws.size(); ++i) {
      const LawResult& l = c.laws[i];
      o << head.str() << CsvRow(study::CsvCell(in.laws[i].law.spec), l.run.ride) << ','
        << l.run.violations << ',' << (l.improvement ? Num(*l.improvement, 9) : "none") << tail;
    }
  }
  return o.str();
}

// comfort-CLASS-SPEED[-rRATIO].png: Wk comfort against the worst tyre load, both grids and each
// law; study.png: each law's improvement against speed.
bool WritePlots(const std::string& dir, const Inputs& in, const std::vector<Case>& cases,
                std::string* error, std::string* warning) {
  std::ostringstream gp, dat;
  dat.precision(9);
  gp << "set grid\nset key outside below\nset terminal pngcairo noenhanced size 1000,700\n";
  const bool with_ratio = in.ratios.size() > 1;
  for (const Case& c : cases) {
    const std::string name = std::string(1, c.road_class) + "-" + Num(c.speed) +
                             (with_ratio ? "-r" + Num(c.motion_ratio) : "");
    std::ostringstream g;
    g.precision(9);
    for (const auto* grid : {&c.uniform, &c.pairs}) {
      for (const FullCarRidePoint& p : *grid)
        g << p.worst_tyre_load_rms_n() << ' ' << p.body_accel_wk_rms << '\n';
      g << "\n\n";
    }
    for (const LawResult& l : c.laws) {
      g << l.run.ride.worst_tyre_load_rms_n() << ' ' << l.run.ride.body_accel_wk_rms << "\n\n\n";
    }
    const std::string file = dir + "/grid-" + name + ".dat";
    if (!WriteAtomically(file, g.str(), error)) return false;
    gp << "set output '" << dir << "/comfort-" << name << ".png'\nset xlabel 'worst tyre load RMS "
       << "[N]'\nset ylabel 'Wk body acc RMS [m/s^2]'\nset title 'class " << c.road_class << ", "
       << Num(c.speed) << " m/s'\nplot '" << file << "' index 0 with linespoints title "
       << "'passive, all four', '' index 1 with points title 'passive, front / rear'";
    for (std::size_t i = 0; i < in.laws.size(); ++i) {
      gp << ", '' index " << i + 2 << " with points pt 7 ps 2 title '"
         << study::GnuplotQuotable(in.laws[i].law.spec) << "'";
    }
    gp << "\n";
  }
  for (std::size_t i = 0; i < in.laws.size(); ++i) {
    if (i > 0) dat << "\n\n";
    for (const Case& c : cases) {
      const auto& imp = c.laws[i].improvement;
      dat << c.speed << ' ' << (imp ? Num(*imp, 9) : std::string("NaN")) << '\n';
    }
  }
  if (!WriteAtomically(dir + "/study.dat", dat.str(), error)) return false;
  gp << "set output '" << dir << "/study.png'\nset xlabel 'speed [m/s]'\nset ylabel 'Wk body acc "
     << "RMS improvement [%]'\nset title 'Full car: gain over the best passive setting with no "
     << "worse tyre load'\nplot ";
  for (std::size_t i = 0; i < in.laws.size(); ++i) {
    gp << (i ? ", " : "") << "'" << dir << "/study.dat' index " << i
       << " using 1:2 with linespoints lw 2 title '" << study::GnuplotQuotable(in.laws[i].law.spec)
       << "'";
  }
  gp << "\n";
  if (!WriteAtomically(dir + "/study.gp", gp.str(), error)) return false;
  const int rc = Gnuplot(dir + "/study.gp", dir + "/gnuplot.log");
  if (rc != 0) *warning = GnuplotWarning(rc, dir);
  return true;
}

}  // namespace

int FullCarStudyCommand(const StudyOptions& o, const Scenario& base) {
  Inputs in;
  in.base = base;
  if (const int rc = ParseInputs(o, &in); rc != 0) return rc;
  std::string dir;
  if (const int rc = study::MakeOutDir(o, &dir); rc != 0) return rc;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Case> cases;
  const std::size_t n = in.ratios.size() * in.classes.size() * in.speeds.size();
  std::string error;
  for (const double ratio : in.ratios) {
    for (const char cls : in.classes) {
      for (const double speed : in.speeds) {
        Case c;
        c.road_class = cls;
        c.speed = speed;
        c.motion_ratio = ratio;
        if (!RunCase(in, cases.size() + 1, n, &c, &error)) return Bad(error);
        cases.push_back(std::move(c));
      }
    }
  }
  const std::string what = "table " + in.table_label + ", plant " + in.plant_label;
  const std::string table = what + "\n\n" + Table(cases, in.laws);
  const nlohmann::json j = Json(in, cases);
  std::string warning;
  if (!WriteAtomically(dir + "/study.txt", table, &error) ||
      !WriteAtomically(dir + "/study.csv", Csv(in, cases), &error) ||
      !WriteAtomically(dir + "/study.json", j.dump(2) + "\n", &error) ||
      !WritePlots(dir, in, cases, &error, &warning)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  if (!warning.empty()) std::fprintf(stderr, "warning: %s\n", warning.c_str());
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (o.json) {
    std::cout << j.dump(2) << std::endl;
  } else {
    std::cout << "mrd-hil study " << base.name << " (full car): " << in.base.duration_s
              << " s per run (scored after " << base.ride_settle_s << " s), road seed "
              << base.road.seed << ", coherence " << base.road_coherence << ", passive grids "
              << in.volts.size() << " (all four) + " << in.pair_volts.size() * in.pair_volts.size()
              << " (front / rear) settings\n"
              << table << "files: " << dir << "/study.txt, study.csv, study.json, study.png, "
              << "comfort-CLASS-SPEED.png (" << Num(wall, 3) << " s wall)\n";
  }
  return std::cout ? 0 : 1;
}

}  // namespace mrd::hil
