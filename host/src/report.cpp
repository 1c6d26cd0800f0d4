#include "mrd/host/report.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <system_error>

#include "mrd/host/atomic_write.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/model_judge.hpp"
#include "mrd/host/plot.hpp"
#include "mrd/host/residuals.hpp"
#include "mrd/host/staging_dir.hpp"

namespace mrd::host {
namespace {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Line styles: data (measured or reference) thick blue, model thinner orange.
constexpr const char* kDataStyle = "lines linewidth 2 linecolor rgb '#1f77b4'";
constexpr const char* kModelStyle = "lines linewidth 1.2 linecolor rgb '#ff7f0e'";
constexpr const char* kErrorStyle = "lines linewidth 1 linecolor rgb '#d62728'";
// Loops (force against x or v) as points: data that are not periodic (random or measured
// excitation) would draw as a scribble of lines.
constexpr const char* kDataPoints = "points pointtype 7 pointsize 0.35 linecolor rgb '#1f77b4'";
constexpr const char* kModelPoints = "points pointtype 7 pointsize 0.2 linecolor rgb '#ff7f0e'";
constexpr const char* kInputStyle = "lines linewidth 1 linecolor rgb '#2ca02c'";

// One data file with its simulation of the reported iteration.
struct DataReport {
  DataSet data;
  std::string name;          // file name, for titles and messages
  std::string stem;          // unique file-name stem of its plots
  std::vector<double> ysim;  // simulated output, raw units (measured in the seed rows)
  SimMetrics metrics;
  std::vector<EnvelopeCheck> envelope;  // inputs against the model's identification range
  std::vector<std::string> warnings;    // envelope warnings
  ResidualAnalysis residuals;
  std::vector<double> j_per_iteration;  // NaN: diverged or not runnable
};

// Unique plot stems: the file's stem, with _2, _3, ... on repeats.
void AssignStems(std::vector<DataReport>& reports) {
  std::set<std::string> used;
  for (DataReport& r : reports) {
    const std::string base = fs::path(r.data.path).stem().string();
    std::string stem = base.empty() ? "data" : base;
    for (int n = 2; used.count(stem) != 0; ++n) stem = fmt::format("{}_{}", base, n);
    used.insert(stem);
    r.stem = stem;
  }
}

// Unit of a signal for physical figures: the toolkit's unit, else the signal's name.
std::string Unit(const std::string& name) {
  const std::string label = SignalLabel(name);
  return label == name ? name : label.substr(name.size() + 2, label.size() - name.size() - 3);
}

std::string FormatJ(double j) { return std::isfinite(j) ? fmt::format("{:.6g}", j) : "-"; }

PlotSeries Series(std::string title, std::vector<double> x, std::vector<double> y,
                  std::string style) {
  PlotSeries s;
  s.title = std::move(title);
  s.x = std::move(x);
  s.y = std::move(y);
  s.style = std::move(style);
  return s;
}

// Force against displacement or velocity: data and model loops.
PlotSpec LoopPlot(const ModelFile& mf, int k, const DataReport& r, const std::string& signal,
                  const std::string& what) {
  const std::string& out = mf.spec.output;
  PlotSpec p;
  p.title = fmt::format("{}: {} vs {}, model iteration {} ({} terms)", r.name, out, what, k,
                        mf.Iteration(k).terms.size());
  p.xlabel = SignalLabel(signal);
  p.ylabel = SignalLabel(out);
  const auto& x = r.data.Column(signal);
  p.series.push_back(Series("measured (data file)", x, r.data.Column(out), kDataPoints));
  p.series.push_back(Series("model (free run)", x, r.ysim, kModelPoints));
  p.width = 900;
  p.height = 700;
  return p;
}

// Output against time (data, model) above the error against time, then each input of the
// model (E, v, ...) present in the data: all over the window w, sample by sample; last, an
// overview of the whole record (envelopes of data and model) with the window marked.
PlotFigure TimePlot(const ModelFile& mf, int k, const DataReport& r, const TimeWindow& w) {
  const std::string& out = mf.spec.output;
  const auto& all_t = r.data.Column("t");
  const SampleRange in = SamplesIn(all_t, w);
  const std::vector<double> t = Slice(all_t, in), y = Slice(r.data.Column(out), in),
                            ysim = Slice(r.ysim, in);
  std::vector<double> e(y.size());
  for (std::size_t i = 0; i < y.size(); ++i) e[i] = y[i] - ysim[i];
  PlotFigure f;
  f.title = fmt::format("{}: model iteration {} ({} terms), fit {:.3f} %", r.name, k,
                        mf.Iteration(k).terms.size(), r.metrics.fit_percent);
  std::vector<std::string> inputs;
  for (std::size_t c = 1; c < mf.channels.size(); ++c) {
    if (r.data.Has(mf.channels[c].name)) inputs.push_back(mf.channels[c].name);
  }
  f.rows = 3 + static_cast<int>(inputs.size());
  f.width = 1400;
  f.height = 1250 + 300 * static_cast<int>(inputs.size());
  PlotSpec a;
  a.title = fmt::format("{} vs time, {:g} .. {:g} s (--window FROM:TO)", out, w.from_s, w.to_s);
  a.xlabel = SignalLabel("t");
  a.ylabel = SignalLabel(out);
  a.series.push_back(Series("measured (data file)", t, y, kDataStyle));
  a.series.push_back(Series("model (free run)", t, ysim, kModelStyle));
  PlotSpec b;
  b.title = fmt::format("error: measured - model (RMSE over the record {:.6g} {})",
                        r.metrics.rmse_physical, Unit(out));
  b.xlabel = SignalLabel("t");
  b.ylabel = "error " + SignalLabel(out);
  b.series.push_back(Series("measured - model", t, std::move(e), kErrorStyle));
  f.panels = {std::move(a), std::move(b)};
  for (const std::string& u : inputs) {
    PlotSpec p;
    p.title = fmt::format("input {} vs time", u);
    p.xlabel = SignalLabel("t");
    p.ylabel = SignalLabel(u);
    p.series.push_back(Series(u + " (data file)", t, Slice(r.data.Column(u), in), kInputStyle));
    f.panels.push_back(std::move(p));
  }
  PlotSpec o;
  o.title = fmt::format("overview: {} over the whole record ({:g} s), min/max envelope", out,
                        all_t.empty() ? 0.0 : all_t.back() - all_t.front());
  o.xlabel = SignalLabel("t");
  o.ylabel = SignalLabel(out);
  PlotSeries data_env = Series("measured (envelope)", {}, {}, kDataStyle);
  Envelope(all_t, r.data.Column(out), 1500, &data_env.x, &data_env.y);
  PlotSeries model_env = Series("model (envelope)", {}, {}, kModelStyle);
  Envelope(all_t, r.ysim, 1500, &model_env.x, &model_env.y);
  o.series = {std::move(data_env), std::move(model_env)};
  o.x_markers = {{w.from_s, "window"}, {w.to_s, ""}};
  f.panels.push_back(std::move(o));
  return f;
}

// Name of validation set v of the model file: its file name when recorded.
std::string ValidationName(const ModelFile& mf, std::size_t v) {
  if (v < mf.validation_data.size()) {
    return "validation " + fs::path(mf.validation_data[v]).filename().string();
  }
  return fmt::format("validation {}", v + 1);
}

// J per iteration: identification, validation sets of the model file, data files.
PlotSpec IterationPlot(const ModelFile& mf, int k, const std::vector<DataReport>& reports) {
  PlotSpec p;
  p.title = fmt::format("{}: cost J per iteration", fs::path(mf.path).filename().string());
  p.xlabel = "iteration";
  p.ylabel = "J (normalised)";
  p.log_y = true;
  p.width = 1100;
  p.height = 750;
  std::vector<double> it, j;
  std::size_t num_val = 0;
  for (const SemIteration& s : mf.iterations) {
    it.push_back(s.iteration);
    j.push_back(s.j);
    num_val = std::max(num_val, s.validation_j.size());
  }
  p.series.push_back(Series("identification J (model file)", it, j,
                            "linespoints linewidth 2 pointtype 7 pointsize 0.8"));
  for (std::size_t v = 0; v < num_val; ++v) {
    std::vector<double> jv;
    for (const SemIteration& s : mf.iterations) {
      jv.push_back(v < s.validation_j.size() ? s.validation_j[v] : kNaN);
    }
    p.series.push_back(Series(fmt::format("{} J (model file)", ValidationName(mf, v)), it, jv,
                              "linespoints linewidth 1.5 pointtype 5 pointsize 0.7"));
  }
  for (const DataReport& r : reports) {
    p.series.push_back(Series(fmt::format("{} J (simulated here)", r.name), it, r.j_per_iteration,
                              "linespoints dashtype 2 linewidth 1.5 pointtype 6 pointsize 1.2"));
  }
  p.x_markers.push_back(
      {static_cast<double>(mf.selected), fmt::format("selected: {}", mf.selected)});
  if (k != mf.selected) {
    p.x_markers.push_back({static_cast<double>(k), fmt::format("reported: {}", k)});
  }
  return p;
}

std::string Summary(const ModelFile& mf, int k, bool k_given,
                    const std::vector<DataReport>& reports, const std::vector<std::string>& notes,
                    const std::vector<std::string>& files) {
  fmt::memory_buffer b;
  auto out = std::back_inserter(b);
  const std::string& y = mf.spec.output;
  const SemIteration& sel = mf.Iteration(mf.selected);
  const SemIteration& it = mf.Iteration(k);
  fmt::format_to(out, "mrd report: model {}\n", mf.path);
  if (!mf.identification_data.empty()) {
    fmt::format_to(
        out, "identified on: {}; validated on: {}\n", fmt::join(mf.identification_data, ", "),
        mf.validation_data.empty() ? std::string("-")
                                   : fmt::format("{}", fmt::join(mf.validation_data, ", ")));
  }
  fmt::format_to(out, "selected iteration: {} ({} terms, J {}; {})\n", mf.selected,
                 sel.terms.size(), FormatJ(sel.j), mf.selection_rule);
  if (!mf.family.empty()) {  // transform family: every combination's score, the choice
    fmt::format_to(out, "transform family ({}):\n", mf.family.rule);
    for (std::size_t c = 0; c < mf.family.combinations.size(); ++c) {
      const FamilyCombination& fc = mf.family.combinations[c];
      fmt::format_to(out, "  {}: score {}, iteration {} ({} terms, J {}){}\n",
                     FamilyMembers(mf.family.regressors, fc), FormatJ(fc.score), fc.selected,
                     fc.terms, FormatJ(fc.j),
                     static_cast<int>(c) == mf.family.chosen ? "  <- chosen" : "");
    }
  }
  fmt::format_to(out, "reported iteration: {} ({} terms, J {}){}\n", k, it.terms.size(),
                 FormatJ(it.j), k_given ? " from --iteration" : "");
  fmt::format_to(out, "channels (normalised = (raw - offset) / scale):");
  for (const ChannelInfo& c : mf.channels) {
    fmt::format_to(out, " {} offset {:.9g} scale {:.9g};", c.name, c.offset, c.scale);
  }
  bool has_range = !mf.channels.empty();
  for (const ChannelInfo& c : mf.channels) has_range = has_range && c.has_range;
  if (has_range) {
    fmt::format_to(out, "\noperating envelope (identification data, raw units):");
    for (const ChannelInfo& c : mf.channels) {
      fmt::format_to(out, " {} [{:.6g}, {:.6g}];", c.name, c.min, c.max);
    }
  }
  fmt::format_to(out, "\nterms of iteration {} (coefficients in normalised units):\n", k);
  for (std::size_t i = 0; i < it.terms.size(); ++i) {
    fmt::format_to(out, "  {:3d}  {:+.12e}  {}\n", i + 1, it.coefficients[i],
                   TermName(mf.spec, it.terms[i]));
  }
  const std::size_t seed = mf.warmup_samples();
  fmt::format_to(out, "\nfit of iteration {} (free run; the first {} sample{} seed{} it):\n", k,
                 seed, seed == 1 ? "" : "s", seed == 1 ? "s" : "");
  for (const DataReport& r : reports) {
    const SimMetrics& m = r.metrics;
    fmt::format_to(out, "  {}: {} samples scored{}\n", r.data.path, m.samples,
                   m.diverged ? ", DIVERGED" : "");
    fmt::format_to(
        out, "    J {:.6g}  MSE {:.6g} (normalised)  MSE {:.6g} {}^2  RMSE {:.6g} {}  (J: {})\n",
        m.j, m.mse, m.mse_physical, Unit(y), m.rmse_physical, Unit(y), CostWeightingName(mf));
    fmt::format_to(out, "    RRSE {:.6g}  fit {:.3f} %  (unweighted; NRMSE = RRSE)\n", m.rrse,
                   m.fit_percent);
    if (r.envelope.empty()) {
      fmt::format_to(out, "    range check: the model file records no envelope\n");
    } else if (!AnyOutside(r.envelope)) {
      fmt::format_to(out, "    range check: every input inside the identification envelope\n");
    }
    for (const std::string& w : r.warnings) fmt::format_to(out, "    {}\n", w);
    std::string res = ResidualSummary(r.residuals, SignalUnit(y));
    for (std::size_t p = 0; (p = res.find('\n', p)) != std::string::npos && p + 1 < res.size();) {
      res.insert(p + 1, "    ");
      p += 5;
    }
    fmt::format_to(out, "    {}", res);
  }
  fmt::format_to(out,
                 "\nJ per iteration (J: {}; '-': not finite, diverged or not runnable; "
                 "'<': reported):\n",
                 CostWeightingName(mf));
  std::vector<std::string> heads = {"iteration", "terms", "identification"};
  std::size_t num_val = 0;
  for (const SemIteration& s : mf.iterations) num_val = std::max(num_val, s.validation_j.size());
  for (std::size_t v = 0; v < num_val; ++v) heads.push_back(ValidationName(mf, v));
  for (const DataReport& r : reports) heads.push_back(r.name);
  const bool stress = mf.spec.stress.enabled;
  if (stress) heads.push_back("stress");  // verdict of the spec's [stress] check, peak |y|
  std::vector<std::size_t> widths;
  for (const auto& h : heads) widths.push_back(std::max<std::size_t>(h.size(), 12));
  fmt::format_to(out, " ");
  for (std::size_t c = 0; c < heads.size(); ++c)
    fmt::format_to(out, " {:>{}}", heads[c], widths[c]);
  fmt::format_to(out, "\n");
  for (std::size_t i = 0; i < mf.iterations.size(); ++i) {
    const SemIteration& s = mf.iterations[i];
    std::vector<std::string> cells = {fmt::format("{}", s.iteration),
                                      fmt::format("{}", s.terms.size()), FormatJ(s.j)};
    for (std::size_t v = 0; v < num_val; ++v) {
      cells.push_back(v < s.validation_j.size() ? FormatJ(s.validation_j[v]) : "-");
    }
    for (const DataReport& r : reports) cells.push_back(FormatJ(r.j_per_iteration[i]));
    if (stress) {
      cells.push_back(!s.stress.checked ? std::string("-")
                      : s.stress.pass   ? fmt::format("pass {:.3g}", s.stress.peak)
                                        : std::string(std::isfinite(s.stress.peak)
                                                          ? fmt::format("FAIL {:.3g}", s.stress.peak)
                                                          : std::string("FAIL diverged")));
    }
    fmt::format_to(out, " ");
    for (std::size_t c = 0; c < cells.size(); ++c) {
      fmt::format_to(out, " {:>{}}", cells[c], widths[c]);
    }
    fmt::format_to(out, "{}\n", s.iteration == k ? " <" : "");
  }
  if (!notes.empty()) {
    fmt::format_to(out, "\nnotes:\n");
    for (const auto& n : notes) fmt::format_to(out, "  {}\n", n);
  }
  fmt::format_to(out, "\nfiles:\n");
  for (const auto& f : files) fmt::format_to(out, "  {}\n", f);
  return fmt::to_string(b);
}

}  // namespace

std::string SignalLabel(const std::string& name) {
  static const std::map<std::string, std::string> kUnits = {
      {"t", "s"}, {"x", "cm"}, {"v", "cm/s"}, {"E", "V"}, {"f", "N"}};
  const auto it = kUnits.find(name);
  return it == kUnits.end() ? name : fmt::format("{} [{}]", name, it->second);
}

ReportResult WriteReport(const ReportOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  const auto progress = [&o](const std::string& line) {
    if (o.progress) o.progress(line);
  };
  if (o.data.empty()) throw InputError("", 0, "--data: no data file");
  CheckOutDir(o.out_dir);

  // Inputs: everything that can be wrong with them is found here, before any output.
  const ModelFile mf = LoadModelFile(o.model);
  const int k = o.iteration.value_or(mf.selected);
  const SemIteration& chosen = mf.Iteration(k);
  std::vector<DataReport> reports;
  for (const std::string& path : o.data) {
    DataReport r;
    r.data = ReadCsv(path, mf.spec.Signals());
    r.name = fs::path(path).filename().string();
    reports.push_back(std::move(r));
  }
  AssignStems(reports);
  for (DataReport& r : reports) {
    progress(fmt::format("report: simulating iteration {} ({} terms) on {}", k, chosen.terms.size(),
                         r.name));
    r.metrics = SimulateModel(mf, k, r.data, &r.ysim);
    r.envelope = CheckEnvelope(mf, r.data);
    r.warnings = EnvelopeWarnings(o.model, r.data.path, r.envelope);
    for (const std::string& w : r.warnings) progress(w);
    progress(fmt::format("report: residual analysis on {}", r.name));
    try {
      r.residuals = AnalyseResiduals(mf, k, r.data, o.max_lag);
    } catch (const std::invalid_argument& e) {
      throw InputError(r.data.path, 0, e.what());
    }
  }
  if (!GnuplotAvailable()) {
    throw std::runtime_error(
        "gnuplot not found on PATH: the plots need it (Debian package gnuplot-nox)");
  }

  // J of every iteration on every data file; a diverging or unrunnable model is a gap.
  std::vector<std::string> notes;
  const int last = mf.iterations.empty() ? 0 : mf.iterations.back().iteration;
  for (DataReport& r : reports) r.j_per_iteration.assign(mf.iterations.size(), kNaN);
  for (std::size_t i = 0; i < mf.iterations.size(); ++i) {
    const int n = mf.iterations[i].iteration;
    for (DataReport& r : reports) {
      progress(fmt::format("report: simulating iteration {}/{} on {}", n, last, r.name));
      try {
        const SimMetrics m = n == k ? r.metrics : SimulateModel(mf, n, r.data);
        if (m.diverged || !std::isfinite(m.j)) {
          notes.push_back(
              fmt::format("{}: iteration {} diverges (gap in J_iterations.png)", r.name, n));
        } else {
          r.j_per_iteration[i] = m.j;
        }
      } catch (const std::exception& e) {
        notes.push_back(fmt::format("{}: iteration {} not simulated: {}", r.name, n, e.what()));
      }
    }
  }
  for (const DataReport& r : reports) {
    if (r.metrics.diverged) {
      notes.push_back(fmt::format("{}: the reported iteration {} diverges", r.name, k));
    }
  }

  // Plots into the staging directory.
  StagingDir staging(o.out_dir, "report");
  std::vector<std::string> names;
  const auto plot = [&](const auto& spec, const std::string& name) {
    progress(fmt::format("report: plotting {}", name));
    PlotPng(spec, staging.File(name));
    names.push_back(name);
  };
  for (const DataReport& r : reports) {
    // A force-displacement loop reads only on periodic motion (random motion: a cloud).
    if (!r.data.Has("x")) {
      notes.push_back(fmt::format("{}: no column 'x': force-displacement loop skipped", r.name));
    } else if (!LooksPeriodic(r.data.Column("x"))) {
      notes.push_back(fmt::format(
          "{}: displacement not periodic: no force-displacement loop (it would be a cloud); "
          "the force-velocity plot and the time plot show the force",
          r.name));
    } else {
      plot(LoopPlot(mf, k, r, "x", "displacement"), r.stem + "_force_displacement.png");
    }
    if (r.data.Has("v")) {
      plot(LoopPlot(mf, k, r, "v", "velocity"), r.stem + "_force_velocity.png");
    } else {
      notes.push_back(fmt::format("{}: no column 'v': force-velocity loop skipped", r.name));
    }
    std::string window_note;
    const TimeWindow w =
        PlotWindow(r.data.Column("t"), o.window ? &*o.window : nullptr, &window_note);
    if (!window_note.empty()) notes.push_back(r.name + ": " + window_note);
    plot(TimePlot(mf, k, r, w), r.stem + "_time.png");
    plot(ResidualPlot(r.residuals,
                      fmt::format("{}: residual correlations, model iteration {}", r.name, k)),
         r.stem + "_residuals.png");
  }
  plot(IterationPlot(mf, k, reports), "J_iterations.png");
  names.push_back("summary.txt");

  std::vector<std::string> files;
  for (const auto& n : names) files.push_back((fs::path(o.out_dir) / n).string());
  ReportResult result;
  result.summary = Summary(mf, k, o.iteration.has_value(), reports, notes, files);
  WriteFileAtomic(staging.File("summary.txt"), result.summary);
  staging.Commit(names);
  result.files = std::move(files);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress(
      fmt::format("report: wrote {} files to {} in {:.1f} s", names.size(), o.out_dir, seconds));
  return result;
}

}  // namespace mrd::host
