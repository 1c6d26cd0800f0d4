// mrd export: an identified model as the firmware's coefficient table (binary and/or C++
// header). Everything is checked and encoded before anything is written.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "mrd/common/cli_checks.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/command_range.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/invertibility.hpp"
#include "mrd/host/model_export.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/table_export.hpp"

namespace mrd::host::cli {
namespace {

struct ExportOptions {
  std::string model;
  std::optional<int> iteration;  // none: the model file's selected iteration
  std::string table, header;
  std::string symbol = "mrd::firmware::kExportedTable";
  std::string input = "E";
  std::optional<double> e_min, e_max;  // [V]; none: command_range.hpp
  std::string profile;                 // device profile: its command range
  bool allow_non_monotone = false;
};

void RunExport(const ExportOptions& o) {
  if (o.table.empty() && o.header.empty()) {
    throw InputError("", 0, "nothing to write: give --table and/or --header");
  }
  for (const std::string* out : {&o.table, &o.header}) {
    if (!out->empty()) CheckOutputPath(*out);
  }
  const ModelFile mf = LoadModelFile(o.model);
  const int k = o.iteration.value_or(mf.selected);
  const SemIteration& it = mf.Iteration(k);  // InputError "no iteration K" when absent
  ExportedTable ex = ExportCheckedTable(mf, {k, o.input, o.e_min, o.e_max, o.profile});
  const CommandRange& range = ex.range;
  for (const std::string& w : range.warnings) fmt::print(stderr, "{}\n", w);
  // A model that fails the invertibility check over the table's command range is refused unless
  // --allow-non-monotone.
  const InvertibilityReport& inv = ex.invertibility;
  if (!inv.pass() && !o.allow_non_monotone) {
    // Short enough for the reason's cut (input_error.cpp): the share and the worst state.
    throw InputError(
        o.model, 0,
        fmt::format("not invertible (--allow-non-monotone exports it anyway): {}; a controller "
                    "inverting it may ask for the wrong command",
                    !inv.structure_problem.empty()
                        ? InvertibilitySummary(inv)
                        : fmt::format("{} of {} states fail ({:.3g} %) in {} on [{:g}, {:g}]{}",
                                      inv.failing(), inv.states(), inv.share_percent(), inv.input,
                                      inv.e_min, inv.e_max,
                                      inv.has_worst ? "; worst: " + DescribeState(inv, inv.worst)
                                                    : std::string())));
  }
  if (!inv.pass()) {
    fmt::print(stderr, "warning: {}: exported although not invertible (--allow-non-monotone): {}\n",
               o.model, InvertibilitySummary(inv));
  }
  const CoefficientTable& table = ex.table;
  const TableBytes bytes = TableImage(table);
  // Encode both forms first, then write both or neither (WriteFilesAtomic).
  std::vector<std::pair<std::string, std::string>> files;
  if (!o.table.empty()) {
    files.emplace_back(o.table,
                       std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  }
  if (!o.header.empty()) {
    try {
      files.emplace_back(o.header, TableHeader(table, o.symbol, bytes));
    } catch (const std::invalid_argument& e) {
      throw InputError("", 0, fmt::format("--symbol: {}", e.what()));
    }
  }
  WriteFilesAtomic(files);
  fmt::print(
      "iteration {} ({} terms, J {:.6g}), input '{}' in [{:.4g}, {:.4g}] V ({}), {} ->{}{}\n", k,
      it.terms.size(), it.j, o.input, range.e_min, range.e_max, range.source,
      ex.envelope ? "operating envelope" : "no envelope (model file predates it)",
      o.table.empty() ? "" : " " + o.table, o.header.empty() ? "" : " " + o.header);
  fmt::print("{}\n", InvertibilitySummary(inv));
}

}  // namespace

void RegisterExport(CLI::App& app) {
  auto o = std::make_shared<ExportOptions>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Write a model iteration as the firmware's coefficient table: binary image "
      "(docs/table_format.md) and/or a C++ header with a constexpr table.");
  cmd->add_option("--model", o->model, "Model file from mrd identify")->required();
  cmd->add_option("--iteration", o->iteration, "Iteration to export (default: the selected one)");
  cmd->add_option("--table", o->table, "Binary table output (.bin)");
  cmd->add_option("--header", o->header, "C++ header output (.hpp)");
  cmd->add_option("--symbol", o->symbol, "Qualified name of the constexpr table in the header")
      ->capture_default_str();
  cmd->add_option("--input", o->input, "Inverted input channel (the command voltage)")
      ->capture_default_str();
  cmd->add_option("--e-min", o->e_min,
                  "Lowest admissible command [V] (default: --profile's, else the lowest the "
                  "identification data reached, at least 0)")
      ->check(mrd::cli::Finite);
  cmd->add_option("--e-max", o->e_max,
                  "Highest admissible command [V] (default: --profile's, else the highest the "
                  "identification data reached)")
      ->check(mrd::cli::Finite);
  cmd->add_option("--profile", o->profile,
                  "Device profile (firmware/profiles/): the table's command range is its "
                  "[command] range, mapped back to E through its calibration");
  cmd->add_flag("--allow-non-monotone", o->allow_non_monotone,
                "Export a model whose force falls as the command rises (dissipative direction) "
                "or turns back somewhere in its envelope (refused otherwise), with a warning");
  cmd->callback([o] { RunExport(*o); });
}

}  // namespace mrd::host::cli
