#include "sweep_command.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "mrd/common/write_atomically.hpp"
#include "mrd/hil/study/sweep.hpp"
#include "report.hpp"
#include "table_check.hpp"

namespace mrd::hil {
namespace {

// Points grouped by the axes after the first (one gnuplot data block each, blank-line
// separated): x the first swept key, then the score columns of the CSV.
std::string PlotData(const SweepGrid& g, const std::vector<SweepScores>& rows,
                     std::vector<std::string>* titles) {
  std::ostringstream o;
  o.precision(9);
  const auto points = g.Points();
  const std::size_t per = g.axes[0].values.size();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (i % per == 0) {
      if (i > 0) o << "\n\n";
      std::string t;
      for (std::size_t a = 1; a < points[i].size(); ++a)
        t += (t.empty() ? "" : ", ") + points[i][a];
      titles->push_back(t);
    }
    const SweepScores& s = rows[i];
    o << g.axes[0].values[i % per] << ' ' << s.error_all << ' ' << s.error_reachable << ' '
      << s.body_accel_rms << ' ' << s.body_accel_off << ' ' << s.body_accel_on << '\n';
  }
  return o.str();
}

// Text inside a gnuplot single-quoted string: a quote doubled.
std::string Quotable(const std::string& v) {
  std::string out;
  for (const char c : v) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out;
}

std::string PlotScript(const std::string& dir, const SweepGrid& g, bool ride,
                       const std::vector<std::string>& titles, const std::string& png,
                       const std::string& what) {
  std::ostringstream o;
  const std::string data = "'" + dir + "/sweep.dat'";
  o << "set terminal pngcairo noenhanced size 1000,600\nset grid\nset key outside below\n"
    << "set output '" << png << "'\nset xlabel '" << g.axes[0].key << "'\n";
  const auto name = [&](std::size_t b, const char* curve) {
    return std::string(curve) + (titles[b].empty() ? "" : " (" + titles[b] + ")");
  };
  if (ride) {
    o << "set ylabel 'body acceleration RMS [m/s^2]'\n"
      << "set title 'Sweep: ride (body acceleration RMS) against " << g.axes[0].key << "; " << what
      << "'\nplot ";
    for (std::size_t b = 0; b < titles.size(); ++b) {
      o << (b ? ", " : "") << data << " index " << b << " using 1:4 with linespoints lw 2 title '"
        << name(b, "controlled") << "', " << data << " index " << b
        << " using 1:5 with lines dt 2 title '" << name(b, "passive-off") << "', " << data
        << " index " << b << " using 1:6 with lines dt 3 title '" << name(b, "passive-on") << "'";
    }
  } else {
    o << "set ylabel '||f-d|| / ||d||'\n"
      << "set title 'Sweep: force tracking error against " << g.axes[0].key << "; " << what
      << "'\nplot ";
    for (std::size_t b = 0; b < titles.size(); ++b) {
      o << (b ? ", " : "") << data << " index " << b << " using 1:3 with linespoints lw 2 title '"
        << name(b, "reachable") << "', " << data << " index " << b
        << " using 1:2 with linespoints dt 2 title '" << name(b, "all") << "'";
    }
  }
  o << "\n";
  return o.str();
}

}  // namespace

int SweepCommand(const std::string& scenario_path, const std::vector<std::string>& sets,
                 RunOptions o, const std::string& out_dir) {
  SweepGrid grid;
  std::string error;
  if (!ParseSweepGrid(sets, &grid, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 2;
  }
  // Every point is read (and checked) before the first run.
  const auto points = grid.Points();
  std::vector<Scenario> scenarios(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::vector<std::string> all = grid.fixed;
    all.insert(all.end(), points[i].begin(), points[i].end());
    if (!LoadScenario(scenario_path, all, &scenarios[i], &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 2;
    }
    if (scenarios[i].channels.any()) {  // its figures are the full car's, not the sweep's
      std::fprintf(stderr,
                   "error: %s: four corners ([channels]) run in mrd-hil run only (the full "
                   "car's study: mrd-hil study)\n",
                   scenario_path.c_str());
      return 2;
    }
  }
  if (access(o.firmware.c_str(), X_OK) != 0) {
    std::fprintf(stderr, "error: %s: not an executable (give --firmware PATH)\n",
                 o.firmware.c_str());
    return 2;
  }
  // What each point runs on: its table (path and CRC) and plant.
  std::vector<std::string> tables, plants;
  for (const Scenario& sc : scenarios) {
    const std::string path = o.table.empty() ? sc.table_file : o.table;
    CoefficientTable t;
    if (!LoadRunTable(path, &t)) return 2;
    tables.push_back(TableLabel(path, t));
    plants.push_back(PlantLabel(sc));
  }
  std::string what;  // the plots' and the table's line: one table and plant, or "per point"
  const bool one_table = std::all_of(tables.begin(), tables.end(),
                                     [&](const std::string& t) { return t == tables[0]; });
  const bool one_plant = std::all_of(plants.begin(), plants.end(),
                                     [&](const std::string& p) { return p == plants[0]; });
  what = "table " + (one_table ? tables[0] : std::string("per point (sweep.csv)")) + ", plant " +
         (one_plant ? plants[0] : std::string("per point (sweep.csv)"));
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec || !std::filesystem::is_directory(out_dir)) {
    std::fprintf(stderr, "error: %s: cannot create the output directory\n", out_dir.c_str());
    return 1;
  }
  o.clock = "lockstep";  // deterministic: the same grid gives the same table
  o.keep_trace = true;
  o.attach = false;
  if (o.startup_timeout_s <= 0.0) o.startup_timeout_s = 10.0;
  std::vector<SweepScores> rows;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < points.size(); ++i) {
    char dir[] = "/tmp/mrd-hil-sweep-XXXXXX";
    if (mkdtemp(dir) == nullptr) {
      std::fprintf(stderr, "error: cannot create a temporary directory\n");
      return 1;
    }
    o.work_dir = dir;
    RunResult r;
    const int rc = RunScenario(scenarios[i], o, &r, &error);
    std::filesystem::remove_all(dir, ec);
    std::string label;
    for (const std::string& p : points[i]) label += (label.empty() ? "" : " ") + p;
    if (rc != 0) {
      std::fprintf(stderr, "error: point %zu (%s): %s\n", i + 1, label.c_str(), error.c_str());
      if (!r.firmware_stderr.empty())
        std::fprintf(stderr, "firmware: %s", r.firmware_stderr.c_str());
      if (r.interrupted != 0) return 128 + r.interrupted;
      return rc == 2 ? 2 : 1;
    }
    rows.push_back(ScoresOf(r));
    rows.back().table = tables[i];
    rows.back().plant = plants[i];
    const SweepScores& s = rows.back();
    std::fprintf(stderr, "[%zu/%zu] %s: %s, %s %.4g (%.1f s wall)\n", i + 1, points.size(),
                 label.c_str(), s.pass ? "PASS" : "FAIL",
                 s.ride ? "body acceleration RMS" : "reachable error",
                 s.ride ? s.body_accel_rms : s.error_reachable, r.wall_s);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::size_t best = BestPoint(rows);
  std::cout << SweepTable(grid, rows) << "ran on: " << what << "\n";
  std::string best_label;
  for (const std::string& p : points[best]) best_label += (best_label.empty() ? "" : " ") + p;
  std::cout << "best: " << best_label << " ("
            << (rows[best].ride ? "lowest body acceleration RMS" : "lowest reachable error")
            << (rows[best].pass ? "" : "; no point passes") << ")\n";
  const std::string csv = out_dir + "/sweep.csv";
  if (!WriteAtomically(csv, SweepCsv(grid, rows), &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  std::vector<std::string> titles;
  const std::string dat = out_dir + "/sweep.dat", gp = out_dir + "/sweep.gp",
                    png = out_dir + "/sweep.png", png_temp = out_dir + "/.sweep.png.tmp";
  const bool ride = rows[0].ride;
  if (!WriteAtomically(dat, PlotData(grid, rows, &titles), &error) ||
      !WriteAtomically(gp, PlotScript(out_dir, grid, ride, titles, png_temp, Quotable(what)),
                       &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  const int rc = Gnuplot(gp, out_dir + "/gnuplot.log");
  if (rc == 0 && std::rename(png_temp.c_str(), png.c_str()) == 0) {
    std::cout << "files: " << csv << ", " << png << " (" << points.size() << " runs, " << wall
              << " s wall)\n";
  } else {
    unlink(png_temp.c_str());
    std::cout << "files: " << csv << " (" << points.size() << " runs, " << wall << " s wall)\n";
    std::fprintf(stderr, "warning: %s\n",
                 rc < 0
                     ? "gnuplot not found (install gnuplot-nox): plot skipped"
                     : ("gnuplot failed (see " + out_dir + "/gnuplot.log): plot skipped").c_str());
  }
  if (!std::cout) return 1;
  return 0;
}

}  // namespace mrd::hil
