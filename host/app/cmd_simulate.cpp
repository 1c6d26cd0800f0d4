// mrd simulate: free-run simulation of an identified model through mrd::ModelRunner.
#include <memory>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"

namespace mrd::host::cli {
namespace {

struct SimulateOptions {
  std::string model;
  std::string data;
  std::optional<int> iteration;
  std::string out;
  bool json = false;
};

void RunSimulate(const SimulateOptions& o) {
  const ModelFile mf = LoadModelFile(o.model);
  const int k = o.iteration.value_or(mf.selected);
  const DataSet data = ReadCsv(o.data, mf.spec.Signals());
  std::vector<double> ysim;
  const SimMetrics m = SimulateModel(mf, k, data, &ysim);
  if (!o.out.empty()) {
    WriteCsv(o.out, {"t", mf.spec.output, mf.spec.output + "_sim"},
             {data.Column("t"), data.Column(mf.spec.output), ysim});
  }
  if (o.json) {
    const nlohmann::json j = {{"iteration", k},
                              {"terms", mf.Iteration(k).terms.size()},
                              {"samples", m.samples},
                              {"J", m.j},
                              {"mse", m.mse},
                              {"mse_physical", m.mse_physical},
                              {"rmse_physical", m.rmse_physical},
                              {"rrse", m.rrse},
                              {"fit_percent", m.fit_percent},
                              {"diverged", m.diverged}};
    fmt::print("{}\n", j.dump());
    return;
  }
  fmt::print("{} on {}: iteration {} ({} terms), {} samples{}\n", o.model, o.data, k,
             mf.Iteration(k).terms.size(), m.samples, m.diverged ? ", DIVERGED" : "");
  fmt::print("  normalised: J {:.6g}  MSE {:.6g}\n", m.j, m.mse);
  fmt::print("  physical:   MSE {:.6g} {}^2  RMSE {:.6g} {}\n", m.mse_physical, mf.spec.output,
             m.rmse_physical, mf.spec.output);
  fmt::print("  RRSE {:.6g}  fit {:.3f} %\n", m.rrse, m.fit_percent);
}

}  // namespace

void RegisterSimulate(CLI::App& app) {
  auto o = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "simulate", "Free-run simulation of a model file on a data set: J, MSE, RRSE, fit %.");
  cmd->add_option("--model", o->model, "Model file (JSON) from mrd identify")->required();
  cmd->add_option("--data", o->data, "Data file (CSV)")->required();
  cmd->add_option("--iteration", o->iteration, "Iteration to simulate (default: selected)");
  cmd->add_option("--out", o->out, "Write t, measured and simulated output (CSV)");
  cmd->add_flag("--json", o->json, "Print one JSON object (J, mse, rrse, fit_percent, ...)");
  cmd->callback([o] { RunSimulate(*o); });
}

}  // namespace mrd::host::cli
