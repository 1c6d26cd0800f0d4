// mrd report: PNG plots (gnuplot) and a summary of a model on data files (host/report.hpp).
#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "mrd/common/cli_checks.hpp"
#include "mrd/host/report.hpp"

namespace mrd::host::cli {
namespace {

void RunReport(ReportOptions o) {
  o.progress = [](const std::string& line) {
    fmt::print(stderr, "{}\n", line);
    std::fflush(stderr);
  };
  const ReportResult r = WriteReport(o);
  fmt::print("{}", r.summary);
}

}  // namespace

void RegisterReport(CLI::App& app) {
  auto o = std::make_shared<ReportOptions>();
  CLI::App* cmd = app.add_subcommand(
      "report",
      "PNG plots and a summary of a model on data files: force-displacement and "
      "force-velocity loops (points), force, error and inputs vs time, residual correlations, J "
      "per iteration; J (weighting named), MSE, RMSE [N], RRSE/NRMSE, fit %, residual lags "
      "outside the 99 % band, inputs outside the identification envelope (also on stderr).");
  cmd->footer(
      "Writes DIR/<stem>_force_displacement.png (when the data has x and it is periodic; "
      "random motion would draw a cloud), "
      "DIR/<stem>_force_velocity.png (when it has v), DIR/<stem>_time.png (output, error, "
      "inputs over a window of a few seconds, and an overview of the whole record), "
      "DIR/<stem>_residuals.png (residual correlations, as mrd resid) per data file, "
      "DIR/J_iterations.png and DIR/summary.txt; the summary is also printed on stdout, "
      "progress on stderr. The files are built in a temporary directory beside DIR (inside DIR "
      "when DIR's parent is not writable), then moved into place (the whole directory when DIR is "
      "absent or empty, else file by "
      "file, replacing files of the same name). Needs gnuplot (Debian: gnuplot-nox).");
  cmd->add_option("--model", o->model, "Model file (JSON) from mrd identify")->required();
  cmd->add_option("--data", o->data, "Data file(s) (CSV), comma separated or repeated")
      ->required()
      ->delimiter(',');
  cmd->add_option("--out", o->out_dir, "Output directory (its parent must exist)")->required();
  cmd->add_option("--iteration", o->iteration, "Iteration to report (default: selected)");
  cmd->add_option("--max-lag", o->max_lag, "Largest lag of the residual correlations [samples]")
      ->check(mrd::cli::FiniteRange(1, 100000))
      ->capture_default_str();
  auto window = std::make_shared<std::string>();
  cmd->add_option("--window", *window, kWindowHelp);
  cmd->callback([o, window] {
    ReportOptions r = *o;
    r.window = WindowFlag(*window);
    RunReport(std::move(r));
  });
}

}  // namespace mrd::host::cli
