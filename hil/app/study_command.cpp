#include "study_command.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "firmware_law.hpp"
#include "full_car_study.hpp"
#include "mrd/common/write_atomically.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/hil/study/passive_baseline.hpp"
#include "passive_report.hpp"
#include "report.hpp"
#include "study_support.hpp"
#include "table_check.hpp"

namespace mrd::hil {
namespace {

using study::Bad;
using study::CsvCell;
using study::GnuplotQuotable;
using study::kBadInput;
using study::Num;
using study::ParseNumbers;
using study::Signed;
using study::Split;

struct LawResult {
  LawRun run;
  PassiveComparison cmp;
};

struct StudyCase {
  char road_class = 'C';
  double speed = 20.0;
  double motion_ratio = 0.7;  // damper / wheel travel
  std::vector<RidePoint> grid;
  std::vector<LawResult> laws;
};

// CLASS-SPEED, with -rRATIO when the study runs several motion ratios.
std::string CaseName(const StudyCase& c, bool with_ratio) {
  return std::string(1, c.road_class) + "-" + Num(c.speed) +
         (with_ratio ? "-r" + Num(c.motion_ratio) : "");
}

bool SeveralRatios(const std::vector<StudyCase>& cases) {
  for (const StudyCase& c : cases) {
    if (c.motion_ratio != cases.front().motion_ratio) return true;
  }
  return false;
}

// The Markdown table: one row per case.
std::string Table(const std::vector<StudyCase>& cases, const std::vector<FirmwareLaw>& laws) {
  std::ostringstream o;
  o << "| class | speed [m/s] | motion ratio | passive-off body acc [m/s^2] "
       "| best passive body acc [m/s^2] | best passive Wk [m/s^2] | best passive tyre load [N]";
  for (const FirmwareLaw& l : laws) {
    o << " | " << l.spec << ": body acc [m/s^2], tyre load [N] | " << l.spec
      << ": vs best passive at no-worse tyre load";
  }
  o << " |\n|---|---|---|---|---|---|---";
  for (std::size_t i = 0; i < laws.size(); ++i) o << "|---|---";
  o << "|\n";
  for (const StudyCase& c : cases) {
    const PassiveBest b = BestOf(c.grid, RideMetric::kBodyAccel);
    const PassiveBest w = BestOf(c.grid, RideMetric::kBodyAccelWk);
    const PassiveBest t = BestOf(c.grid, RideMetric::kTyreLoad);
    o << "| " << c.road_class << " | " << Num(c.speed) << " | " << Num(c.motion_ratio) << " | "
      << Num(c.grid[0].body_accel_rms) << " | " << Num(b.value) << " (" << Num(b.volts, 3)
      << " V) | " << Num(w.value) << " (" << Num(w.volts, 3) << " V) | " << Num(t.value) << " ("
      << Num(t.volts, 3) << " V)";
    for (const LawResult& l : c.laws) {
      o << " | " << Num(l.run.ride.body_accel_rms) << ", " << Num(l.run.ride.tyre_load_rms_n)
        << " | ";
      if (l.cmp.comfort_at_holding) {
        o << "**" << Signed(*l.cmp.comfort_at_holding_improvement) << "** (vs "
          << Num(l.cmp.comfort_at_holding->value) << " at "
          << Num(l.cmp.comfort_at_holding->volts, 3) << " V); Wk "
          << Signed(*l.cmp.wk_at_holding_improvement);
      } else {
        o << "none (tyre load below every passive setting)";
      }
    }
    o << " |\n";
  }
  return o.str();
}

std::string Csv(const std::vector<StudyCase>& cases, const std::vector<FirmwareLaw>& laws,
                const std::string& table, const std::string& plant) {
  std::ostringstream o;
  o.precision(9);
  o << "class,speed_m_s,motion_ratio,law,passive_off_body_accel_rms,best_body_accel_rms,"
       "best_body_accel_v,best_body_accel_wk_rms,best_body_accel_wk_v,best_tyre_load_rms_n,"
       "best_tyre_load_v,best_travel_rms_cm,best_travel_v,law_body_accel_rms,"
       "law_body_accel_wk_rms,law_tyre_load_rms_n,law_travel_rms_cm,law_mean_v,"
       "law_violations,equal_holding_v,equal_holding_body_accel_rms,"
       "comfort_improvement_percent,equal_holding_wk_v,equal_holding_body_accel_wk_rms,"
       "wk_comfort_improvement_percent,table,plant\n";
  for (const StudyCase& c : cases) {
    for (std::size_t i = 0; i < laws.size(); ++i) {
      const LawResult& l = c.laws[i];
      o << c.road_class << ',' << c.speed << ',' << c.motion_ratio << ',' << laws[i].spec << ','
        << c.grid[0].body_accel_rms;
      for (const PassiveBest& b : l.cmp.best) o << ',' << b.value << ',' << b.volts;
      const RidePoint& p = l.run.ride;
      o << ',' << p.body_accel_rms << ',' << p.body_accel_wk_rms << ',' << p.tyre_load_rms_n << ','
        << p.travel_rms_cm << ',' << p.volts << ',' << l.run.violations;
      if (l.cmp.comfort_at_holding) {
        o << ',' << l.cmp.comfort_at_holding->volts << ',' << l.cmp.comfort_at_holding->value << ','
          << *l.cmp.comfort_at_holding_improvement << ',' << l.cmp.wk_at_holding->volts << ','
          << l.cmp.wk_at_holding->value << ',' << *l.cmp.wk_at_holding_improvement;
      } else {
        o << ",none,none,none,none,none,none";
      }
      o << ',' << CsvCell(table) << ',' << CsvCell(plant) << '\n';
    }
  }
  return o.str();
}

nlohmann::json Json(const Scenario& s, double step, const std::vector<StudyCase>& cases,
                    const std::vector<FirmwareLaw>& laws, const std::string& table,
                    const std::string& plant) {
  nlohmann::json j;
  j["scenario"] = s.name;
  j["file"] = s.path;
  j["table"] = table;
  j["plant"] = plant;
  j["duration_s"] = s.duration_s;
  j["settle_s"] = s.ride_settle_s;
  j["road_seed"] = s.road.seed;
  j["passive_step_v"] = step;
  j["e_min"] = 0.0;
  j["e_max"] = s.e_max;
  for (const FirmwareLaw& l : laws) j["laws"].push_back(l.spec);
  j["cases"] = nlohmann::json::array();
  for (const StudyCase& c : cases) {
    nlohmann::json jc;
    jc["class"] = std::string(1, c.road_class);
    jc["speed_m_s"] = c.speed;
    jc["motion_ratio"] = c.motion_ratio;
    jc["passive_off"] = RidePointJson(c.grid[0]);
    for (const RideMetric m : kRideMetrics) {
      const PassiveBest b = BestOf(c.grid, m);
      jc["best_passive"][RideMetricKey(m)] = {{"volts", b.volts}, {"value", b.value}};
    }
    jc["grid"] = nlohmann::json::array();
    for (const RidePoint& p : c.grid) jc["grid"].push_back(RidePointJson(p));
    jc["laws"] = nlohmann::json::array();
    for (std::size_t i = 0; i < laws.size(); ++i) {
      const LawResult& l = c.laws[i];
      nlohmann::json jl;
      jl["law"] = laws[i].spec;
      jl["ride"] = RidePointJson(l.run.ride);
      jl["violations"] = l.run.violations;
      jl["safe_periods"] = l.run.safe_periods;
      for (std::size_t m = 0; m < kNumRideMetrics; ++m) {
        jl["improvement_percent"][RideMetricKey(kRideMetrics[m])] = l.cmp.improvement[m];
      }
      if (l.cmp.comfort_at_holding) {
        const RidePoint& p = c.grid[l.cmp.comfort_at_holding->index];
        jl["comfort_at_equal_road_holding"] = {
            {"volts", p.volts},
            {"body_accel_rms", p.body_accel_rms},
            {"tyre_load_rms_n", p.tyre_load_rms_n},
            {"improvement_percent", *l.cmp.comfort_at_holding_improvement}};
      } else {
        jl["comfort_at_equal_road_holding"] = nullptr;
      }
      jl["wk_comfort_at_equal_road_holding"] = WkAtHoldingJson(c.grid, l.cmp);
      jc["laws"].push_back(jl);
    }
    j["cases"].push_back(jc);
  }
  return j;
}

// Plots: comfort-CASE.png per case (CaseName), study.png (improvement against speed).
bool WritePlots(const std::string& dir, const std::vector<StudyCase>& cases,
                const std::vector<FirmwareLaw>& laws, const std::string& what, std::string* error,
                std::string* warning) {
  std::ostringstream gp;
  gp << "set grid\nset key inside\n";
  const bool with_ratio = SeveralRatios(cases);
  for (const StudyCase& c : cases) {
    const std::string name = CaseName(c, with_ratio);
    const std::string dat = dir + "/grid-" + name + ".dat";
    if (!WriteAtomically(dat, GridData(c.grid), error)) return false;
    std::vector<PlotPoint> points;
    for (std::size_t i = 0; i < laws.size(); ++i)
      points.push_back({laws[i].spec, c.laws[i].run.ride});
    gp << "set terminal pngcairo noenhanced size 1400,600\nset output '" << dir << "/comfort-"
       << name << ".png'\nset multiplot layout 1,2\n"
       << ComfortPanels(dat, points,
                        "class " + std::string(1, c.road_class) + ", " + Num(c.speed) +
                            " m/s, motion ratio " + Num(c.motion_ratio) + "; " + what)
       << "unset multiplot\n";
  }
  // Improvement at equal road holding against speed: one block per (ratio x) class x law.
  std::ostringstream dat;
  dat.precision(9);
  std::vector<std::string> titles;
  std::set<std::pair<double, char>> groups;
  for (const StudyCase& c : cases) groups.insert({c.motion_ratio, c.road_class});
  for (const auto& [ratio, cls] : groups) {
    for (std::size_t i = 0; i < laws.size(); ++i) {
      if (!titles.empty()) dat << "\n\n";
      titles.push_back((with_ratio ? "r " + Num(ratio) + ", " : std::string()) + "class " +
                       std::string(1, cls) + ", " + laws[i].spec);
      for (const StudyCase& c : cases) {
        if (c.road_class != cls || c.motion_ratio != ratio) continue;
        const auto& imp = c.laws[i].cmp.comfort_at_holding_improvement;
        dat << c.speed << ' ' << (imp ? Num(*imp, 9) : std::string("NaN")) << '\n';
      }
    }
  }
  if (!WriteAtomically(dir + "/study.dat", dat.str(), error)) return false;
  gp << "set terminal pngcairo noenhanced size 1000,600\nset output '" << dir << "/study.png'\n"
     << "set key outside below\nset xlabel 'speed [m/s]'\n"
     << "set ylabel 'body acc RMS improvement [%]'\n"
     << "set title 'Comfort gain over the best passive setting with no worse tyre-load RMS; "
     << what << "'\n"
     << "plot ";
  for (std::size_t b = 0; b < titles.size(); ++b) {
    gp << (b ? ", " : "") << "'" << dir << "/study.dat' index " << b
       << " using 1:2 with linespoints lw 2 title '" << titles[b] << "'";
  }
  gp << "\n";
  const std::string script = dir + "/study.gp";
  if (!WriteAtomically(script, gp.str(), error)) return false;
  const int rc = Gnuplot(script, dir + "/gnuplot.log");
  if (rc != 0) *warning = GnuplotWarning(rc, dir);
  return true;
}

// The study's inputs from its options: the base scenario (--duration applied), the passive
// grid's step and voltages, the road classes, speeds and laws. 0, or the exit code after the
// message.
struct StudyInputs : study::BaseInputs {
  std::vector<char> classes;
  std::vector<double> speeds;
  std::vector<double> ratios;  // motion ratios
  std::vector<FirmwareLaw> laws;
};

// --motion-ratios: each in [0.01, 1] (the scenario key's range), no repeats; "" the scenario's.
int ParseMotionRatios(const StudyOptions& o, StudyInputs* in) {
  if (o.motion_ratios.empty()) {
    in->ratios.push_back(in->base.car.motion_ratio);
    return 0;
  }
  const auto ratio = [](double x) { return x >= 0.01 && x <= 1.0; };
  return ParseNumbers("--motion-ratios", o.motion_ratios, ratio, "a motion ratio in [0.01, 1]",
                      &in->ratios);
}

int ParseStudyInputs(const StudyOptions& o, StudyInputs* in) {
  Scenario& base = in->base;
  std::string error;
  if (!LoadScenario(o.scenario, &base, &error)) return Bad(error);
  if (!base.quarter_car) {
    return Bad("--scenario: " + o.scenario +
               " is not a quarter car or full car ([plant] model = \"quarter-car\" or "
               "\"full-car\")");
  }
  // What a study cannot run: it feeds the law the plant's signals in process, without faults
  // or the GPIO routing (mrd-hil run and sweep run those).
  if (!base.faults.empty()) {
    return Bad("--scenario: " + o.scenario +
               " has [[fault]] entries: the study runs no faults (mrd-hil run or sweep do)");
  }
  if (base.gpio.any()) {
    return Bad("--scenario: " + o.scenario +
               " routes signals over [gpio]: the study feeds the law in process without it "
               "(mrd-hil run or sweep do)");
  }
  if (const int rc = study::LoadBaseInputs(o, in); rc != 0) return rc;
  if (const int rc = study::ParseClassesAndSpeeds(o, &in->classes, &in->speeds); rc != 0) {
    return rc;
  }
  if (const int rc = ParseMotionRatios(o, in); rc != 0) return rc;
  // The scenario's [firmware] safety keys, as mrd-hil run writes them into the config.
  std::ostringstream safety;
  safety << "\n[safety]\nmax_age_ms = " << base.max_age_ms
         << "\nrecover_periods = " << base.recover_periods
         << "\nvelocity_limit = " << base.velocity_limit << "\n";
  for (const std::string& spec : Split(o.laws)) {
    FirmwareLaw law;
    const std::string sections = spec.find("safety.") == std::string::npos ? safety.str() : "";
    if (!MakeFirmwareLaw(spec, base.skyhook_gain, base.e_max, sections, &law, &error) ||
        !CheckFirmwareLaw(law, in->table, &error)) {
      return Bad(error);
    }
    for (const FirmwareLaw& k : in->laws) {
      if (k.spec == spec) return Bad("--laws '" + o.laws + "': names " + spec + " twice");
    }
    in->laws.push_back(law);
  }
  if (in->laws.empty()) return Bad("--laws: no law given");
  return 0;
}

// One motion ratio x road class x speed (as set in c): the passive grid and each law, with
// progress on stderr. false: *error (a law could not run).
bool RunStudyCase(const StudyInputs& in, std::size_t index, std::size_t n_cases,
                  const std::function<double()>& wall, StudyCase* c, std::string* error) {
  Scenario s = in.base;
  RoadClassFromChar(c->road_class, &s.road.road_class);
  s.car.speed_m_s = c->speed;
  s.car.motion_ratio = c->motion_ratio;
  std::fprintf(stderr,
               "[%zu/%zu] class %c, %g m/s, motion ratio %g: passive grid (%zu settings)...\n",
               index, n_cases, c->road_class, c->speed, c->motion_ratio, in.volts.size());
  c->grid = RunPassiveGrid(s, in.step);
  const PassiveBest best = BestOf(c->grid, RideMetric::kBodyAccel);
  std::fprintf(stderr, "[%zu/%zu]   best passive body acc RMS %.4f m/s^2 at %.3g V (%.1f s)\n",
               index, n_cases, best.value, best.volts, wall());
  QuarterCarPlant plant = MakeQuarterCar(s);
  for (const FirmwareLaw& law : in.laws) {
    LawResult lr;
    if (!RunFirmwareLaw(law, in.table, &plant, s.duration_s, s.ride_settle_s, &lr.run, error)) {
      return false;
    }
    lr.cmp = Compare(c->grid, lr.run.ride);
    std::fprintf(
        stderr, "[%zu/%zu]   %s: body acc RMS %.4f m/s^2, tyre load RMS %.1f N, %s\n", index,
        n_cases, law.spec.c_str(), lr.run.ride.body_accel_rms, lr.run.ride.tyre_load_rms_n,
        lr.cmp.comfort_at_holding_improvement ? (Signed(*lr.cmp.comfort_at_holding_improvement) +
                                                 " vs the best passive at no-worse tyre load")
                                                    .c_str()
                                              : "no passive setting with a tyre load this low");
    c->laws.push_back(lr);
  }
  return true;
}

}  // namespace

int StudyCommand(const StudyOptions& o) {
  {
    Scenario probe;
    std::string why;
    if (LoadScenario(o.scenario, &probe, &why) && probe.full_car) {
      return FullCarStudyCommand(o, probe);
    }
  }
  StudyInputs in;
  if (const int rc = ParseStudyInputs(o, &in); rc != 0) return rc;
  const Scenario& base = in.base;
  const std::vector<FirmwareLaw>& laws = in.laws;
  std::string error;
  std::string dir;
  if (const int rc = study::MakeOutDir(o, &dir); rc != 0) return rc;

  const auto t0 = std::chrono::steady_clock::now();
  const std::function<double()> wall = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  std::vector<StudyCase> cases;
  const std::size_t n_cases = in.ratios.size() * in.classes.size() * in.speeds.size();
  for (const double ratio : in.ratios) {
    for (const char cls : in.classes) {
      for (const double speed : in.speeds) {
        StudyCase c;
        c.road_class = cls;
        c.speed = speed;
        c.motion_ratio = ratio;
        if (!RunStudyCase(in, cases.size() + 1, n_cases, wall, &c, &error)) return Bad(error);
        cases.push_back(std::move(c));
      }
    }
  }
  const std::string what = "table " + in.table_label + ", plant " + in.plant_label;
  const std::string table = what + "\n\n" + Table(cases, laws);
  const nlohmann::json j = Json(base, in.step, cases, laws, in.table_label, in.plant_label);
  std::string warning;
  if (!WriteAtomically(dir + "/study.txt", table, &error) ||
      !WriteAtomically(dir + "/study.csv", Csv(cases, laws, in.table_label, in.plant_label),
                       &error) ||
      !WriteAtomically(dir + "/study.json", j.dump(2) + "\n", &error) ||
      !WritePlots(dir, cases, laws, GnuplotQuotable(what), &error, &warning)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  if (!warning.empty()) std::fprintf(stderr, "warning: %s\n", warning.c_str());
  if (o.json) {
    std::cout << j.dump(2) << std::endl;
  } else {
    std::cout << "mrd-hil study " << base.name << ": " << base.duration_s
              << " s per run (scored after " << base.ride_settle_s << " s), road seed "
              << base.road.seed << ", passive grid " << in.volts.size() << " settings (0 .. "
              << base.e_max << " V, step " << in.step << " V)\n"
              << table << "files: " << dir << "/study.txt, study.csv, study.json, study.png, "
              << (in.ratios.size() > 1 ? "comfort-CLASS-SPEED-rRATIO.png ("
                                       : "comfort-CLASS-SPEED.png (")
              << cases.size() * (in.volts.size() + laws.size()) << " runs, " << Num(wall(), 3)
              << " s wall)\n";
  }
  return std::cout ? 0 : 1;
}

}  // namespace mrd::hil
