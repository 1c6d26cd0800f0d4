// mrd simulate: free-run simulation of an identified model through mrd::ModelRunner.
#include <fmt/format.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/invertibility.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/model_judge.hpp"

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
  if (!o.out.empty()) CheckOutputPath(o.out);
  const ModelFile mf = LoadModelFile(o.model);
  const int k = o.iteration.value_or(mf.selected);
  const DataSet data = ReadCsv(o.data, mf.spec.Signals());
  std::vector<double> ysim;
  const SimMetrics m = SimulateModel(mf, k, data, &ysim);
  if (!o.out.empty()) {
    WriteCsv(o.out, {"t", mf.spec.output, mf.spec.output + "_sim"},
             {data.Column("t"), data.Column(mf.spec.output), ysim});
  }
  const std::vector<EnvelopeCheck> env = CheckEnvelope(mf, data);
  for (const auto& w : EnvelopeWarnings(o.model, o.data, env)) fmt::print(stderr, "{}\n", w);
  // Invertibility in the command on this data's states and the envelope grid.
  const bool has_command = !ModelCommand(mf).empty();
  const InvertibilityReport inv =
      has_command ? CheckModelInvertibility(mf, k, std::span<const DataSet>(&data, 1))
                  : InvertibilityReport{};
  if (has_command && !inv.pass()) {
    fmt::print(stderr, "warning: {} on {}: {}\n", o.model, o.data, InvertibilitySummary(inv));
  }
  if (o.json) {
    nlohmann::json j = MetricsJson(mf, m);
    j["iteration"] = k;
    j["terms"] = mf.Iteration(k).terms.size();
    j["envelope"] = EnvelopeJson(env);
    j["outside_envelope"] = AnyOutside(env);
    if (has_command) j["invertibility"] = InvertibilityJson(inv);
    fmt::print("{}\n", j.dump());
    return;
  }
  const std::string& y = mf.spec.output;
  const std::string unit = SignalUnit(y).empty() ? y : SignalUnit(y);
  fmt::print("{} on {}: iteration {} ({} terms), {} samples{}\n", o.model, o.data, k,
             mf.Iteration(k).terms.size(), m.samples, m.diverged ? ", DIVERGED" : "");
  fmt::print("  physical:   MSE {:.6g} {}^2  RMSE {:.6g} {}\n", m.mse_physical, unit,
             m.rmse_physical, unit);
  fmt::print(
      "  unweighted: RRSE {:.6g}  fit {:.3f} %  (NRMSE = RRSE = ||{} - sim|| / ||{} - mean||)\n",
      m.rrse, m.fit_percent, y, y);
  fmt::print("  normalised: J {:.6g} ({})  MSE {:.6g}\n", m.j, CostWeightingName(mf), m.mse);
  if (has_command) fmt::print("  {}\n", InvertibilitySummary(inv));
}

}  // namespace

void RegisterSimulate(CLI::App& app) {
  auto o = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Free-run simulation of a model file on a data set: RMSE (output unit), NRMSE, fit %, J "
      "with its weighting; inputs outside the model's identification envelope warned on stderr.");
  cmd->add_option("--model", o->model, "Model file (JSON) from mrd identify")->required();
  cmd->add_option("--data", o->data, "Data file (CSV)")->required();
  cmd->add_option("--iteration", o->iteration, "Iteration to simulate (default: selected)");
  cmd->add_option("--out", o->out, "Write t, measured and simulated output (CSV)");
  cmd->add_flag(
      "--json", o->json,
      "Print one JSON object (J, J_weighting, rmse, rmse_unit, nrmse, fit_percent, envelope, ...)");
  cmd->callback([o] { RunSimulate(*o); });
}

}  // namespace mrd::host::cli
