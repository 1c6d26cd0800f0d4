// mrd compare: several models on several data files, one table (host/compare.hpp).
#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "mrd/host/compare.hpp"

namespace mrd::host::cli {
namespace {

struct CompareCli {
  CompareOptions options;
  bool json = false;
};

void RunCompare(CompareCli c) {
  c.options.progress = [](const std::string& line) {
    fmt::print(stderr, "{}\n", line);
    std::fflush(stderr);
  };
  const CompareResult r = CompareModels(c.options);
  for (const std::string& w : r.warnings) fmt::print(stderr, "{}\n", w);
  if (c.json) {
    fmt::print("{}\n", r.json.dump());
  } else {
    fmt::print("{}", r.table);
    for (const std::string& f : r.files) fmt::print("wrote {}\n", f);
  }
}

}  // namespace

void RegisterCompare(CLI::App& app) {
  auto c = std::make_shared<CompareCli>();
  CLI::App* cmd = app.add_subcommand(
      "compare",
      "Several models on several data files, one table: fit %, RMSE (output unit), NRMSE, J "
      "with its weighting, terms, diverged, inputs outside the identification envelope.");
  cmd->footer(
      "Each model's selected iteration runs free (as mrd simulate) on each data file; a data "
      "file must hold the signals of every model. Warnings (inputs outside a model's "
      "identification envelope) and progress go to stderr. With --out DIR: DIR/compare.txt "
      "(the table), DIR/compare.json and DIR/<stem>_compare.png per data file (measured output "
      "and every model's free run over a window, and the whole record's envelopes below; "
      "needs gnuplot), built in a temporary directory and moved "
      "into place. Bad or missing files: exit 2, nothing written.");
  cmd->add_option("--model", c->options.models, "Model file(s) (JSON), comma separated or repeated")
      ->required()
      ->delimiter(',');
  cmd->add_option("--data", c->options.data, "Data file(s) (CSV), comma separated or repeated")
      ->required()
      ->delimiter(',');
  cmd->add_option("--out", c->options.out_dir,
                  "Output directory for the table and the overlay plots (its parent must exist)");
  cmd->add_flag("--json", c->json, "Print the table as one JSON object instead of text");
  auto window = std::make_shared<std::string>();
  cmd->add_option("--window", *window, kWindowHelp);
  cmd->callback([c, window] {
    CompareCli run = *c;
    run.options.window = WindowFlag(*window);
    RunCompare(std::move(run));
  });
}

}  // namespace mrd::host::cli
