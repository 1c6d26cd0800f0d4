// mrd resid: residual analysis of a model on a data file (host/residuals.hpp).
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "mrd/common/cli_checks.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/model_judge.hpp"
#include "mrd/host/plot.hpp"
#include "mrd/host/residuals.hpp"
#include "mrd/host/staging_dir.hpp"

namespace mrd::host::cli {
namespace {

namespace fs = std::filesystem;

struct ResidOptions {
  std::string model;
  std::string data;
  std::string out;
  std::optional<int> iteration;
  int max_lag = 50;
  bool json = false;
};

void RunResid(const ResidOptions& o) {
  if (!o.out.empty()) CheckOutDir(o.out);
  const ModelFile mf = LoadModelFile(o.model);
  const int k = o.iteration.value_or(mf.selected);
  mf.Iteration(k);  // InputError when absent
  const DataSet data = ReadCsv(o.data, mf.spec.Signals());
  if (!o.out.empty() && !GnuplotAvailable()) {
    throw std::runtime_error(
        "gnuplot not found on PATH: the plot needs it (Debian package gnuplot-nox)");
  }
  const std::vector<EnvelopeCheck> env = CheckEnvelope(mf, data);
  for (const auto& w : EnvelopeWarnings(o.model, o.data, env)) fmt::print(stderr, "{}\n", w);
  fmt::print(stderr, "resid: simulating iteration {} on {} ({} rows)\n", k, o.data, data.rows());
  std::fflush(stderr);
  ResidualAnalysis a;
  try {
    a = AnalyseResiduals(mf, k, data, o.max_lag);
  } catch (const std::invalid_argument& e) {
    throw InputError("", 0, e.what());
  }
  const std::string unit = SignalUnit(mf.spec.output);
  const std::string text = fmt::format("mrd resid: model {} iteration {} on {}\n{}", o.model, k,
                                       o.data, ResidualSummary(a, unit));
  std::vector<std::string> files;
  if (!o.out.empty()) {
    StagingDir staging(o.out, "resid");
    const std::string stem = fs::path(o.data).stem().string();
    const std::string png = (stem.empty() ? "data" : stem) + "_residuals.png";
    PlotPng(ResidualPlot(a, fmt::format("{} on {}: residual correlations (iteration {})",
                                        fs::path(o.model).filename().string(),
                                        fs::path(o.data).filename().string(), k)),
            staging.File(png));
    WriteFileAtomic(staging.File("residuals.txt"), text);
    WriteFileAtomic(staging.File("residuals.json"), ResidualJson(a).dump(2) + "\n");
    staging.Commit({png, "residuals.txt", "residuals.json"});
    for (const auto& n : {png, std::string("residuals.txt"), std::string("residuals.json")}) {
      files.push_back((fs::path(o.out) / n).string());
    }
  }
  if (o.json) {
    nlohmann::json j = ResidualJson(a);
    j["model"] = o.model;
    j["data"] = o.data;
    j["iteration"] = k;
    j["envelope"] = EnvelopeJson(env);
    j["outside_envelope"] = AnyOutside(env);
    j["files"] = files;
    fmt::print("{}\n", j.dump());
    return;
  }
  fmt::print("{}", text);
  for (const auto& f : files) fmt::print("wrote {}\n", f);
}

}  // namespace

void RegisterResid(CLI::App& app) {
  auto o = std::make_shared<ResidOptions>();
  CLI::App* cmd = app.add_subcommand(
      "resid",
      "Residual analysis of a model on a data file: autocorrelation of the free-run and "
      "one-step-ahead residuals, their cross-correlation with each input, 99 % bands.");
  cmd->footer(
      "Free-run residual: measured - simulated output (model fed its own past output); "
      "one-step residual: measured - predicted from measured past outputs. Both over the "
      "scored samples (after the warm-up rows). Band: +-2.58/sqrt(N); the lags outside are "
      "listed (lag 0 of an autocorrelation is 1 and not counted). A white residual "
      "independent of the inputs stays inside. With --out DIR: DIR/<stem>_residuals.png, "
      "DIR/residuals.txt, DIR/residuals.json (needs gnuplot). Inputs outside the model's "
      "identification envelope: a warning on stderr.");
  cmd->add_option("--model", o->model, "Model file (JSON)")->required();
  cmd->add_option("--data", o->data, "Data file (CSV)")->required();
  cmd->add_option("--iteration", o->iteration, "Iteration (default: selected)");
  cmd->add_option("--max-lag", o->max_lag, "Largest lag [samples]")
      ->check(mrd::cli::FiniteRange(1, 100000))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Output directory for the plot and the numbers");
  cmd->add_flag("--json", o->json, "Print one JSON object (correlations, bands, lags outside)");
  cmd->callback([o] { RunResid(*o); });
}

}  // namespace mrd::host::cli
