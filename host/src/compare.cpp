#include "mrd/host/compare.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <set>

#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/invertibility.hpp"
#include "mrd/host/plot.hpp"
#include "mrd/host/report.hpp"
#include "mrd/host/staging_dir.hpp"

namespace mrd::host {
namespace {

namespace fs = std::filesystem;

// Distinct colours for the models' lines (cycled); measured data thick grey-blue.
constexpr const char* kColours[] = {"#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                    "#8c564b", "#e377c2", "#17becf", "#bcbd22"};

std::string Cell(double v, const char* fmt_spec) {
  return std::isfinite(v) ? fmt::format(fmt::runtime(fmt_spec), v) : std::string("-");
}

std::string Table(const CompareResult& r) {
  std::vector<std::vector<std::string>> cells = {{"model", "data", "fit %", "RMSE", "NRMSE", "J",
                                                  "J weighting", "terms", "diverged",
                                                  "not invertible", "outside envelope"}};
  for (const CompareRow& row : r.rows) {
    std::string env;
    for (const EnvelopeCheck& e : row.envelope) {
      if (e.outside == 0) continue;
      if (!env.empty()) env += "; ";
      env += fmt::format("{} {:.1f} % (+{:.3g}{})", e.channel, 100.0 * e.outside_share(),
                         e.largest_excursion, e.unit.empty() ? "" : " " + e.unit);
    }
    const SimMetrics& m = row.metrics;
    cells.push_back(
        {row.model, row.data, Cell(m.fit_percent, "{:.2f}"),
         std::isfinite(m.rmse_physical)
             ? fmt::format("{:.4g}{}", m.rmse_physical, row.unit.empty() ? "" : " " + row.unit)
             : "-",
         Cell(m.rrse, "{:.4f}"), Cell(m.j, "{:.4g}"), row.weighting, fmt::format("{}", row.terms),
         m.diverged ? "yes" : "no",
         row.invertibility_fail_percent < 0.0
             ? std::string("-")
             : fmt::format("{:.3g} %", row.invertibility_fail_percent),
         env.empty() ? "-" : env});
  }
  std::vector<std::size_t> w(cells.front().size(), 0);
  for (const auto& line : cells)
    for (std::size_t c = 0; c < line.size(); ++c) w[c] = std::max(w[c], line[c].size());
  fmt::memory_buffer b;
  auto out = std::back_inserter(b);
  for (const auto& line : cells) {
    for (std::size_t c = 0; c < line.size(); ++c) {
      const bool left = c < 2 || c == 6 || c + 1 == line.size();
      if (left) {
        fmt::format_to(out, "{}{:<{}}", c == 0 ? "" : "  ", line[c],
                       c + 1 == line.size() ? 0 : w[c]);
      } else {
        fmt::format_to(out, "  {:>{}}", line[c], w[c]);
      }
    }
    fmt::format_to(out, "\n");
  }
  fmt::format_to(out,
                 "free run of each model's selected iteration; NRMSE = ||y - ysim|| / "
                 "||y - mean(y)|| (unweighted), fit % = 100 (1 - NRMSE); RMSE in the output's "
                 "unit; J in normalised units with the model's weighting (rel: 1/max(|y_n|, "
                 "floor); mse: none); not invertible: share of states (this data and the "
                 "model's envelope grid) where the force falls as the command rises in the "
                 "dissipative direction or turns back\n");
  return fmt::to_string(b);
}

// Unique file stems of the data files: their stem, with _2, _3, ... on repeats.
std::vector<std::string> Stems(const std::vector<std::string>& paths) {
  std::set<std::string> used;
  std::vector<std::string> out;
  for (const std::string& p : paths) {
    const std::string base =
        fs::path(p).stem().string().empty() ? "data" : fs::path(p).stem().string();
    std::string stem = base;
    for (int n = 2; used.count(stem) != 0; ++n) stem = fmt::format("{}_{}", base, n);
    used.insert(stem);
    out.push_back(stem);
  }
  return out;
}

}  // namespace

CompareResult CompareModels(const CompareOptions& o) {
  const auto progress = [&o](const std::string& line) {
    if (o.progress) o.progress(line);
  };
  if (o.models.empty()) throw InputError("", 0, "--model: no model file");
  if (o.data.empty()) throw InputError("", 0, "--data: no data file");
  if (!o.out_dir.empty()) CheckOutDir(o.out_dir);

  // Inputs first: every model and every data file, each with the signals of every model.
  std::vector<ModelFile> models;
  std::vector<std::string> signals;
  for (const std::string& path : o.models) {
    models.push_back(LoadModelFile(path));
    for (const std::string& s : models.back().spec.Signals()) {
      if (std::find(signals.begin(), signals.end(), s) == signals.end()) signals.push_back(s);
    }
  }
  for (std::size_t i = 1; i < models.size(); ++i) {
    if (models[i].spec.output != models[0].spec.output) {
      throw InputError(o.models[i], 0,
                       fmt::format("output '{}' differs from '{}' of {}", models[i].spec.output,
                                   models[0].spec.output, o.models[0]));
    }
  }
  std::vector<DataSet> data;
  for (const std::string& path : o.data) data.push_back(ReadCsv(path, signals));
  if (!o.out_dir.empty() && !GnuplotAvailable()) {
    throw std::runtime_error(
        "gnuplot not found on PATH: the plots need it (Debian package gnuplot-nox)");
  }

  CompareResult r;
  std::vector<std::vector<std::vector<double>>> ysim(models.size());  // [model][data]
  for (std::size_t mi = 0; mi < models.size(); ++mi) {
    const ModelFile& mf = models[mi];
    for (std::size_t di = 0; di < data.size(); ++di) {
      progress(fmt::format("compare: simulating {} on {}", o.models[mi], o.data[di]));
      CompareRow row;
      row.model = o.models[mi];
      row.data = o.data[di];
      row.iteration = mf.selected;
      row.terms = mf.Iteration(mf.selected).terms.size();
      row.weighting = CostWeightingShort(mf);
      row.unit = SignalUnit(mf.spec.output);
      std::vector<double> y;
      row.metrics = SimulateModel(mf, mf.selected, data[di], &y);
      ysim[mi].push_back(std::move(y));
      row.envelope = CheckEnvelope(mf, data[di]);
      if (!ModelCommand(mf).empty()) {
        const InvertibilityReport inv =
            CheckModelInvertibility(mf, mf.selected, std::span<const DataSet>(&data[di], 1));
        row.invertibility_fail_percent = inv.share_percent();
        row.invertibility = InvertibilityJson(inv);
        if (!inv.pass()) {
          r.warnings.push_back(
              fmt::format("warning: {} on {}: {}", row.model, row.data, InvertibilitySummary(inv)));
        }
      }
      for (auto& w : EnvelopeWarnings(row.model, row.data, row.envelope)) r.warnings.push_back(w);
      r.rows.push_back(std::move(row));
    }
  }
  r.table = Table(r);
  nlohmann::json rows = nlohmann::json::array();
  for (std::size_t i = 0; i < r.rows.size(); ++i) {
    const CompareRow& row = r.rows[i];
    nlohmann::json j = MetricsJson(models[i / data.size()], row.metrics);
    j["model"] = row.model;
    j["data"] = row.data;
    j["iteration"] = row.iteration;
    j["terms"] = row.terms;
    j["envelope"] = EnvelopeJson(row.envelope);
    j["outside_envelope"] = AnyOutside(row.envelope);
    if (!row.invertibility.is_null()) j["invertibility"] = row.invertibility;
    rows.push_back(std::move(j));
  }
  r.json = {{"rows", rows}, {"warnings", r.warnings}};

  if (o.out_dir.empty()) return r;
  StagingDir staging(o.out_dir, "compare");
  std::vector<std::string> names;
  const std::vector<std::string> stems = Stems(o.data);
  const std::string& out = models[0].spec.output;
  for (std::size_t di = 0; di < data.size(); ++di) {
    // The window sample by sample above, the whole record's envelopes below.
    const auto& all_t = data[di].Column("t");
    std::string note;
    const TimeWindow w = PlotWindow(all_t, o.window ? &*o.window : nullptr, &note);
    if (!note.empty()) r.warnings.push_back(o.data[di] + ": " + note);
    const SampleRange in = SamplesIn(all_t, w);
    PlotSpec p;
    p.title =
        fmt::format("{}: measured and free-run {} of {} model(s), {:g} .. {:g} s",
                    fs::path(o.data[di]).filename().string(), out, models.size(), w.from_s, w.to_s);
    p.xlabel = SignalLabel("t");
    p.ylabel = SignalLabel(out);
    PlotSpec ov;
    ov.title = fmt::format("overview: the whole record ({:g} s), min/max envelope",
                           all_t.empty() ? 0.0 : all_t.back() - all_t.front());
    ov.xlabel = SignalLabel("t");
    ov.ylabel = SignalLabel(out);
    ov.x_markers = {{w.from_s, "window"}, {w.to_s, ""}};
    const auto add = [&](std::string title, const std::vector<double>& y, std::string style) {
      p.series.push_back({title, Slice(all_t, in), Slice(y, in), style});
      PlotSeries e{std::move(title), {}, {}, std::move(style)};
      Envelope(all_t, y, 1500, &e.x, &e.y);
      ov.series.push_back(std::move(e));
    };
    add("measured", data[di].Column(out), "lines linewidth 2.5 linecolor rgb '#1f77b4'");
    for (std::size_t mi = 0; mi < models.size(); ++mi) {
      const CompareRow& row = r.rows[mi * data.size() + di];
      add(fmt::format("{} (fit {} %{})", fs::path(o.models[mi]).filename().string(),
                      Cell(row.metrics.fit_percent, "{:.1f}"),
                      row.metrics.diverged ? ", diverged" : ""),
          ysim[mi][di],
          fmt::format("lines linewidth 1.2 linecolor rgb '{}'",
                      kColours[mi % (sizeof kColours / sizeof kColours[0])]));
    }
    PlotFigure fig;
    fig.panels = {std::move(p), std::move(ov)};
    fig.rows = 2;
    fig.width = 1400;
    fig.height = 1100;
    const std::string name = stems[di] + "_compare.png";
    progress(fmt::format("compare: plotting {}", name));
    PlotPng(fig, staging.File(name));
    names.push_back(name);
  }
  WriteFileAtomic(staging.File("compare.txt"), r.table);
  names.push_back("compare.txt");
  WriteFileAtomic(staging.File("compare.json"), r.json.dump(2) + "\n");
  names.push_back("compare.json");
  staging.Commit(names);
  for (const auto& n : names) r.files.push_back((fs::path(o.out_dir) / n).string());
  return r;
}

}  // namespace mrd::host
