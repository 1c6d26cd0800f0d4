#include "report.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "mrd/common/gnuplot.hpp"
#include "passive_report.hpp"

extern char** environ;

namespace mrd::hil {
namespace {

nlohmann::json Stats(const LatencyStats& l) {
  return {{"count", l.count}, {"median", l.median_us}, {"p99", l.p99_us}, {"max", l.max_us}};
}

nlohmann::json Opt(const std::optional<std::int64_t>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

// As the summary's stream prints it (4 significant digits).
std::string Num(double v) {
  std::ostringstream s;
  s.precision(4);
  s << v;
  return s.str();
}

}  // namespace

int Gnuplot(const std::string& script, const std::string& log) {
  return mrd::common::RunGnuplot(script, log, nullptr);
}

std::string GnuplotWarning(int rc, const std::string& dir) {
  return rc < 0 ? "gnuplot not found (install gnuplot-nox): plots skipped"
                : "gnuplot failed (see " + dir + "/gnuplot.log): plots incomplete";
}

// A four-corner run (corners_run.hpp): the full car's ride, each corner, each fault per corner.
nlohmann::json CornersJson(const CornersResult& c) {
  const FullCarRidePoint& p = c.ride;
  nlohmann::json j = {{"fault_policy", c.fault_policy},
                      {"body_law", c.body_law},
                      {"commands_fnv1a", c.commands_fnv1a},
                      {"grants", c.grants},
                      {"ride",
                       {{"settle_s", c.settle_s},
                        {"samples", p.samples},
                        {"body_accel_rms", p.body_accel_rms},
                        {"body_accel_wk_rms", p.body_accel_wk_rms},
                        {"pitch_rate_rms", p.pitch_rate_rms},
                        {"roll_rate_rms", p.roll_rate_rms},
                        {"tyre_load_rms_n", p.tyre_load_rms_n},
                        {"worst_tyre_load_rms_n", p.worst_tyre_load_rms_n()},
                        {"lift_off", p.lift_off},
                        {"mean_volts_front", p.volts_front},
                        {"mean_volts_rear", p.volts_rear}}}};
  nlohmann::json corners = nlohmann::json::array();
  for (const CornerFigures& f : c.corners) {
    corners.push_back({{"name", f.name},
                       {"profile", f.profile},
                       {"commands", f.commands},
                       {"safe_commands", f.safe_commands},
                       {"driven_steps", f.driven_steps},
                       {"invariant_violations", f.invariant_violations},
                       {"command_timeouts", f.command_timeouts},
                       {"heartbeat_timeouts", f.heartbeat_timeouts},
                       {"mean_command_v", f.mean_command_v},
                       {"published", f.port.published},
                       {"received", f.port.received},
                       {"rejected", f.port.rejected}});
  }
  j["per_corner"] = corners;
  nlohmann::json faults = nlohmann::json::array();
  for (const CornerFaultResult& f : c.faults) {
    nlohmann::json per = nlohmann::json::array();
    for (const CornerFaultResult::PerCorner& pc : f.corners) {
      per.push_back({{"periods_to_safe_state", Opt(pc.safe)},
                     {"detection_to_safe_periods", f.detection && pc.safe
                                                       ? nlohmann::json(*pc.safe - *f.detection)
                                                       : nlohmann::json(nullptr)},
                     {"safe_steps", pc.safe_steps},
                     {"commanding_steps", pc.commanding_steps},
                     {"periods_to_recovery", Opt(pc.recovery)}});
    }
    faults.push_back({{"kind", FaultKindName(f.fault.kind)},
                      {"corner", f.fault.corner},
                      {"at_s", f.fault.at_s},
                      {"duration_s", f.fault.duration_s},
                      {"onset_step", f.onset_step},
                      {"clear_step", f.clear_step},
                      {"periods_to_detection", Opt(f.detection)},
                      {"per_corner", per},
                      {"ok", f.ok},
                      {"why", f.why}});
  }
  j["faults"] = faults;
  return j;
}

nlohmann::json SummaryJson(const Scenario& s, const RunResult& r) {
  nlohmann::json j;
  j["scenario"] = s.name.empty() ? s.path : s.name;
  j["file"] = s.path;
  j["transport"] = r.transport;
  j["clock"] = r.clock;
  j["law"] = s.law;
  j["duration_s"] = s.duration_s;
  j["pass"] = r.pass;
  j["failures"] = r.failures;
  j["steps"] = r.steps;
  j["commands"] = r.commands;
  j["invariant_violations"] = r.invariant_violations;
  j["command_timeouts"] = r.command_timeouts;
  j["heartbeat_timeouts"] = r.heartbeat_timeouts;
  j["driven_steps"] = r.driven_steps;
  j["safe_commands"] = r.safe_commands;
  const TrackingScores& t = r.tracking;
  j["tracking"] = {
      {"steps", t.steps},
      {"reachable_steps", t.reachable_steps},
      {"reachable_share", t.reachable_share},
      {"error_all", t.error_all},
      {"error_reachable", t.error_reachable},
      {"passive_off", {{"error_all", t.off_all}, {"error_reachable", t.off_reachable}}},
      {"passive_on", {{"error_all", t.on_all}, {"error_reachable", t.on_reachable}}},
      {"rms_force_n", t.rms_force_n},
      {"rms_demand_n", t.rms_demand_n}};
  if (r.replay) {
    j["replay"] = {{"samples", r.replay->samples},
                   {"fit_percent", r.replay->fit_percent},
                   {"rmse_n", r.replay->rmse_n}};
  }
  if (r.ride) {
    const auto fig = [](const RideFigures& f) {
      return nlohmann::json{{"samples", f.samples},
                            {"body_accel_rms", f.body_accel_rms},
                            {"travel_rms_cm", f.travel_rms_cm},
                            {"tyre_load_rms_n", f.tyre_load_rms_n},
                            {"max_travel_cm", f.max_travel_cm},
                            {"lift_off", f.lift_off}};
    };
    j["ride"] = {{"settle_s", s.ride_settle_s},
                 {"controlled", fig(r.ride->controlled)},
                 {"passive_off", fig(r.ride->passive_off)},
                 {"passive_on", fig(r.ride->passive_on)}};
  }
  if (r.structure) {
    const auto fig = [](const StructureFigures& f) {
      const auto three = [](const double(&v)[3]) { return nlohmann::json{v[0], v[1], v[2]}; };
      return nlohmann::json{{"samples", f.samples},
                            {"peak_x_cm", three(f.peak_x_cm)},
                            {"rms_x_cm", three(f.rms_x_cm)},
                            {"peak_drift_cm", three(f.peak_d_cm)},
                            {"rms_drift_cm", three(f.rms_d_cm)},
                            {"peak_accel_cm_s2", three(f.peak_xa_cm_s2)},
                            {"rms_accel_cm_s2", three(f.rms_xa_cm_s2)},
                            {"peak_force_n", f.peak_force_n},
                            {"rms_force_n", f.rms_force_n}};
    };
    j["structure"] = {{"controlled", fig(r.structure->controlled)},
                      {"passive_off", fig(r.structure->passive_off)},
                      {"passive_on", fig(r.structure->passive_on)}};
  }
  if (r.passive) j["passive"] = PassiveJson(*r.passive, s.e_max);
  if (r.corners) j["corners"] = CornersJson(*r.corners);
  if (s.plant_model != nullptr) {
    const PlantModel& pm = *s.plant_model;
    j["plant_model"] = {{"file", pm.file},
                        {"iteration", pm.iteration},
                        {"terms", pm.model.num_terms},
                        {"envelope", pm.has_envelope},
                        {"input_holds", r.plant_holds ? r.plant_holds->input_holds : 0},
                        {"force_holds", r.plant_holds ? r.plant_holds->force_holds : 0}};
  }
  nlohmann::json faults = nlohmann::json::array();
  for (const FaultResult& f : r.faults) {
    faults.push_back(
        {{"kind", FaultKindName(f.fault.kind)},
         {"at_s", f.fault.at_s},
         {"duration_s", f.fault.duration_s},
         {"onset_step", f.onset_step},
         {"clear_step", f.clear_step},
         {"periods_to_detection", Opt(f.detection)},
         {"periods_to_safe_state", Opt(f.safe)},
         {"detection_to_safe_periods",
          f.detection && f.safe ? nlohmann::json(*f.safe - *f.detection) : nlohmann::json(nullptr)},
         {"periods_to_recovery", Opt(f.recovery)},
         {"detection_required", f.detection_required},
         {"ok", f.ok},
         {"why", f.why}});
  }
  j["faults"] = faults;
  nlohmann::json fw = {{"exit", r.firmware_exit}, {"starts", r.firmware_starts}};
  fw["summary"] = nlohmann::json::parse(r.firmware_json, nullptr, false);
  if (fw["summary"].is_discarded()) fw["summary"] = nullptr;
  j["firmware"] = fw;
  for (const auto& [name, c] : r.ports) {
    j["ports"][name] = {
        {"published", c.published}, {"received", c.received}, {"rejected", c.rejected}};
  }
  // Wall-clock figures: everything outside "timing" is deterministic in lockstep.
  j["timing"] = {{"wall_s", r.wall_s},
                 {"speed_x", r.speed_x},
                 {"late_steps", r.late_steps},
                 {"latency_us", Stats(r.latency)},
                 {"wake_jitter_us", Stats(r.wake_jitter)}};
  return j;
}

std::string SummaryText(const Scenario& s, const RunResult& r) {
  std::ostringstream o;
  o.precision(4);
  const TrackingScores& t = r.tracking;
  o << "mrd-hil run " << (s.name.empty() ? s.path : s.name) << " (" << r.transport << ", "
    << r.clock << ", law " << s.law << ", " << s.duration_s << " s): " << (r.pass ? "PASS" : "FAIL")
    << "\n";
  o << "  steps " << r.steps << ", commands " << r.commands << ", invariant violations "
    << r.invariant_violations << ", command timeouts " << r.command_timeouts
    << ", heartbeat timeouts " << r.heartbeat_timeouts << "\n";
  if (r.replay) {
    o << "  replay: plant force vs measured f over " << r.replay->samples << " steps: fit "
      << r.replay->fit_percent << " %, RMSE " << r.replay->rmse_n << " N\n";
  }
  if (r.corners) {
    const CornersResult& c = *r.corners;
    const FullCarRidePoint& p = c.ride;
    o << "  four corners (" << c.body_law << ", fault policy " << c.fault_policy
      << "): body accel RMS " << p.body_accel_rms << " m/s^2 (Wk " << p.body_accel_wk_rms
      << "), pitch " << p.pitch_rate_rms << " rad/s, roll " << p.roll_rate_rms
      << " rad/s, worst tyre load " << p.worst_tyre_load_rms_n() << " N; commands "
      << c.commands_fnv1a << "\n";
    for (const CornerFigures& f : c.corners) {
      o << "    " << f.name << ": " << f.commands << " commands (" << f.safe_commands
        << " safe), mean " << f.mean_command_v << " V\n";
    }
    for (const CornerFaultResult& f : c.faults) {
      o << "    fault " << FaultKindName(f.fault.kind) << " on "
        << (f.fault.corner < 0 ? std::string("every corner") : c.corners[f.fault.corner].name)
        << ": " << (f.ok ? "ok" : "FAILED: " + f.why) << "\n";
    }
  } else if ((!r.ride || s.law == "force") && s.law != "open-loop" && !r.structure) {
    // n/a: nothing to normalise by (no step, or a zero demand).
    const auto all = [&](double v) { return t.all_scored ? Num(v) : std::string("n/a"); };
    const auto reach = [&](double v) { return t.reachable_scored ? Num(v) : std::string("n/a"); };
    o << "  tracking ||f-d||/||d|| over " << t.steps << " controlled steps (" << t.reachable_steps
      << " reachable, " << Num(100.0 * t.reachable_share) << " %): all " << all(t.error_all)
      << ", reachable " << reach(t.error_reachable) << "\n";
    o << "    passive-off (0 V): all " << all(t.off_all) << ", reachable " << reach(t.off_reachable)
      << "; passive-on (E_max): all " << all(t.on_all) << ", reachable " << reach(t.on_reachable)
      << "\n";
  }
  if (s.plant_model != nullptr) {
    const PlantModel& pm = *s.plant_model;
    o << "  plant: model " << pm.file << " iteration " << pm.iteration << " ("
      << static_cast<int>(pm.model.num_terms) << " terms), envelope "
      << (pm.has_envelope ? "held" : "none in the file") << ": samples with v, x or E held "
      << (r.plant_holds ? r.plant_holds->input_holds : 0) << ", force held "
      << (r.plant_holds ? r.plant_holds->force_holds : 0) << "\n";
  }
  if (r.ride) {
    const auto line = [&](const char* name, const RideFigures& f) {
      o << "    " << name << ": body acceleration RMS " << f.body_accel_rms << " m/s^2, travel RMS "
        << f.travel_rms_cm << " cm, tyre load RMS " << f.tyre_load_rms_n << " N\n";
    };
    o << "  ride after " << s.ride_settle_s << " s:\n";
    line("controlled ", r.ride->controlled);
    line("passive-off", r.ride->passive_off);
    line("passive-on ", r.ride->passive_on);
  }
  if (r.structure) {
    // The in-process study's table (docs/structure.md): x, d [cm]; xa [cm/s^2]; f [N].
    char buf[256];
    o << "  structure, peak | x1 x2 x3 [cm] | d1 d2 d3 [cm] | xa1 xa2 xa3 [cm/s^2] | f [N]:\n";
    const auto peak = [&](const char* name, const StructureFigures& f) {
      std::snprintf(buf, sizeof buf,
                    "    %-15s %.4f %.4f %.4f | %.4f %.4f %.4f | %.0f %.0f %.0f | %.0f\n", name,
                    f.peak_x_cm[0], f.peak_x_cm[1], f.peak_x_cm[2], f.peak_d_cm[0], f.peak_d_cm[1],
                    f.peak_d_cm[2], f.peak_xa_cm_s2[0], f.peak_xa_cm_s2[1], f.peak_xa_cm_s2[2],
                    f.peak_force_n);
      o << buf;
    };
    peak(s.law.c_str(), r.structure->controlled);
    peak("passive-off", r.structure->passive_off);
    peak("passive-on", r.structure->passive_on);
    o << "  structure, RMS (same units):\n";
    const auto rms = [&](const char* name, const StructureFigures& f) {
      std::snprintf(
          buf, sizeof buf, "    %-15s %.4f %.4f %.4f | %.4f %.4f %.4f | %.0f %.0f %.0f | %.0f\n",
          name, f.rms_x_cm[0], f.rms_x_cm[1], f.rms_x_cm[2], f.rms_d_cm[0], f.rms_d_cm[1],
          f.rms_d_cm[2], f.rms_xa_cm_s2[0], f.rms_xa_cm_s2[1], f.rms_xa_cm_s2[2], f.rms_force_n);
      o << buf;
    };
    rms(s.law.c_str(), r.structure->controlled);
    rms("passive-off", r.structure->passive_off);
    rms("passive-on", r.structure->passive_on);
  }
  if (r.passive) o << PassiveText(*r.passive);
  for (const FaultResult& f : r.faults) {
    const auto p = [](const std::optional<std::int64_t>& v) {
      return v ? std::to_string(*v) : std::string("-");
    };
    o << "  fault " << FaultKindName(f.fault.kind) << " at " << f.fault.at_s << " s: detection "
      << p(f.detection) << ", safe " << p(f.safe) << ", recovery " << p(f.recovery) << " periods"
      << (f.ok ? "" : "  FAILED: " + f.why) << "\n";
  }
  o << "  firmware exit " << r.firmware_exit << " (" << r.firmware_starts << " start(s))\n";
  o << "  wall " << r.wall_s << " s (" << r.speed_x << "x real time); latency ";
  if (r.latency.count > 0) {
    o << "median " << r.latency.median_us << " us, p99 " << r.latency.p99_us << " us";
  } else {
    o << "n/a (no command echoed a sample)";
  }
  if (r.clock == "realtime") {
    o << "; wake-up jitter median " << r.wake_jitter.median_us << " us, p99 "
      << r.wake_jitter.p99_us << " us, max " << r.wake_jitter.max_us << " us";
  }
  o << "\n";
  for (const std::string& f : r.failures) o << "  failed: " << f << "\n";
  return o.str();
}

namespace {

// overview.dat: per signal (one gnuplot block each, in this order: demand, force, passive-off,
// passive-on force, command, applied; body acceleration controlled, passive-off, passive-on for
// a quarter car) the whole run's min/max envelope (Envelope, 1500 buckets).
std::string OverviewData(const RunResult& r) {
  std::vector<double> t;
  for (const StepRecord& k : r.trace) t.push_back(k.t);
  std::vector<double StepRecord::*> fields = {&StepRecord::demand,    &StepRecord::force,
                                              &StepRecord::force_off, &StepRecord::force_on,
                                              &StepRecord::command,   &StepRecord::applied};
  if (r.ride) {
    for (auto f :
         {&StepRecord::body_accel, &StepRecord::body_accel_off, &StepRecord::body_accel_on}) {
      fields.push_back(f);
    }
  }
  std::ostringstream o;
  o.precision(9);
  for (std::size_t i = 0; i < fields.size(); ++i) {
    std::vector<double> y, et, ey;
    for (const StepRecord& k : r.trace) y.push_back(k.*fields[i]);
    Envelope(t, y, 1500, &et, &ey);
    if (i > 0) o << "\n\n";
    for (std::size_t j = 0; j < et.size(); ++j) o << et[j] << ' ' << ey[j] << '\n';
  }
  return o.str();
}

}  // namespace

bool WriteOutputs(const std::string& dir, const nlohmann::json& summary, const RunResult& r,
                  const TimeWindow* window, std::string* error, std::string* warning) {
  {
    std::ofstream f(dir + "/summary.json");
    f << summary.dump(2) << "\n";
    if (!f) {
      *error = dir + "/summary.json: cannot write";
      return false;
    }
  }
  {
    std::ofstream f(dir + "/trace.csv");
    const bool ride = r.ride.has_value();
    f << "t,x,v,demand,force,force_off,force_on,command,applied,safe,driven,reachable,causes,"
         "command_age_ms"
      << (ride ? ",body_accel,body_accel_off,body_accel_on\n" : "\n");
    f.precision(9);
    for (const StepRecord& k : r.trace) {
      f << k.t << ',' << k.x << ',' << k.v << ',' << k.demand << ',' << k.force << ','
        << k.force_off << ',' << k.force_on << ',' << k.command << ',' << k.applied << ',' << k.safe
        << ',' << k.driven << ',' << k.reachable << ',' << k.causes << ',' << k.command_age_ms;
      if (ride) f << ',' << k.body_accel << ',' << k.body_accel_off << ',' << k.body_accel_on;
      f << '\n';
    }
    if (!f) {
      *error = dir + "/trace.csv: cannot write";
      return false;
    }
  }
  if (r.corners) {  // a four-corner run: its periods (trace.csv has the header only)
    std::ofstream f(dir + "/corners.csv");
    f << "t,heave_accel,pitch_rate,roll_rate";
    for (const char* c : {"fl", "fr", "rl", "rr"}) {
      f << ",command_" << c << ",applied_" << c << ",safe_" << c << ",causes_" << c;
    }
    f << '\n';
    f.precision(9);
    for (const CornerStep& k : r.corners->trace) {
      f << k.t << ',' << k.heave_accel << ',' << k.pitch_rate << ',' << k.roll_rate;
      for (std::size_t i = 0; i < 4; ++i) {
        f << ',' << k.command[i] << ',' << k.applied[i] << ',' << k.safe[i] << ',' << k.causes[i];
      }
      f << '\n';
    }
    if (!f) {
      *error = dir + "/corners.csv: cannot write";
      return false;
    }
  }
  if (r.trace.empty()) return true;
  // Time plots: the window sample by sample above, the whole run's envelope below.
  std::vector<double> t;
  for (const StepRecord& k : r.trace) t.push_back(k.t);
  std::string note;
  const TimeWindow w = PlotWindow(t, window, &note);
  if (!note.empty()) *warning = note;
  std::ofstream(dir + "/overview.dat") << OverviewData(r);
  const std::string script = dir + "/plots.gp";
  {
    std::ofstream g(script);
    const std::string trace = "'" + dir + "/trace.csv'", ov = "'" + dir + "/overview.dat'";
    char range[96];
    std::snprintf(range, sizeof range, "%.9g:%.9g", w.from_s, w.to_s);
    // Opens a figure of a windowed panel (title what) and its overview; the caller plots the
    // window, then Overview() the envelope blocks.
    const auto open = [&](const std::string& png, const std::string& what,
                          const std::string& ylabel) {
      g << "set datafile separator ','\nset terminal pngcairo noenhanced size 1200,900\n"
        << "set output '" << dir << "/" << png << "'\nset multiplot layout 2,1\n"
        << "set xrange [" << range << "]\nset ylabel '" << ylabel << "'\nset title '" << what
        << ", " << w.from_s << " .. " << w.to_s << " s (--window FROM:TO)'\n";
    };
    const auto overview = [&](const std::string& what) {
      g << "set datafile separator whitespace\nset autoscale x\nunset y2label\nunset y2tics\n"
        << "set autoscale y2\nset arrow 1 from " << w.from_s << ", graph 0 to " << w.from_s
        << ", graph 1 nohead dt 2\nset arrow 2 from " << w.to_s << ", graph 0 to " << w.to_s
        << ", graph 1 nohead dt 2\nset title 'overview: " << what
        << ", the whole run (min/max envelope; the window between the dashed lines)'\n";
    };
    const auto close = [&] { g << "unset arrow 1\nunset arrow 2\nunset multiplot\n"; };
    g << "set grid\nset key outside below\nset xlabel 't [s]'\n";
    open("tracking.png", "Force tracking: plant force vs demand, passive-off (0 V) and passive-on",
         "force [N]");
    g << "plot " << trace << " every ::1 using 1:4 with lines lw 2 title 'demand', "
      << "'' every ::1 using 1:5 with lines title 'force (controlled)', "
      << "'' every ::1 using 1:6 with lines dt 2 title 'passive-off', "
      << "'' every ::1 using 1:7 with lines dt 3 title 'passive-on'\n";
    overview("demand and force");
    g << "plot " << ov << " index 0 with lines lw 2 title 'demand', '' index 1 with lines title "
      << "'force (controlled)'\n";
    close();
    open("command.png", "Command received, voltage applied by the simulated driver, safe state",
         "voltage [V]");
    g << "set y2label 'safe'\nset y2range [-0.1:1.1]\nset y2tics 0,1,1\n"
      << "plot " << trace << " every ::1 using 1:8 with lines title 'command', "
      << "'' every ::1 using 1:9 with lines title 'applied', "
      << "'' every ::1 using 1:10 axes x1y2 with steps title 'safe'\n";
    overview("command and applied voltage");
    g << "plot " << ov << " index 4 with lines title 'command', '' index 5 with lines title "
      << "'applied'\n";
    close();
    if (r.ride) {
      open("ride.png", "Quarter car: body acceleration, controlled vs passive-off and passive-on",
           "body acceleration [m/s^2]");
      g << "plot " << trace << " every ::1 using 1:17 with lines dt 3 title 'passive-on', "
        << "'' every ::1 using 1:16 with lines dt 2 title 'passive-off', "
        << "'' every ::1 using 1:15 with lines lw 2 title 'controlled'\n";
      overview("body acceleration");
      g << "plot " << ov << " index 8 with lines dt 3 title 'passive-on', '' index 7 with lines "
        << "dt 2 title 'passive-off', '' index 6 with lines lw 2 title 'controlled'\n";
      close();
    }
    g << "set autoscale x\nset autoscale y\nset terminal pngcairo size 1200,600\n";
    if (r.passive) {
      // The passive grid with the controlled run, and the body-acceleration PSDs.
      std::ofstream(dir + "/passive.dat") << GridData(r.passive->grid);
      std::ofstream(dir + "/psd.dat") << PsdData(*r.passive);
      g << "set datafile separator whitespace\nunset y2label\nunset y2tics\nset key inside\n"
        << "set terminal pngcairo noenhanced size 1400,600\nset output '" << dir
        << "/comfort.png'\n"
        << "set multiplot layout 1,2\n"
        << ComfortPanels(dir + "/passive.dat", {{"controlled", r.passive->controlled}}, "")
        << "unset multiplot\n"
        << "set terminal pngcairo noenhanced size 1000,600\nset output '" << dir << "/psd.png'\n"
        << "set logscale xy\nset format y '%.0e'\nset xlabel 'f [Hz]'\nset ylabel 'body "
           "acceleration PSD [(m/s^2)^2/Hz]'\n"
        << "set title 'Body acceleration PSD (Welch, Hann, 50 % overlap)'\nset xrange [0.2:100]\n"
        << "plot '" << dir << "/psd.dat' using 1:2 with lines dt 2 title 'passive-off (0 V)', "
        << "'' using 1:3 with lines title 'best passive (" << r.passive->comparison.best[0].volts
        << " V)', '' using 1:4 with lines lw 2 title 'controlled'\n";
    }
  }
  const int rc = Gnuplot(script, dir + "/gnuplot.log");
  if (rc != 0) *warning = GnuplotWarning(rc, dir);
  return true;
}

}  // namespace mrd::hil
