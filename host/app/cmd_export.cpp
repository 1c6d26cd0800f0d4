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
#include "mrd/host/input_error.hpp"
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
  double e_min = 0.0, e_max = 2.25;  // [V]
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
  bool envelope = false;
  const CoefficientTable table = ExportTable(mf, k, o.input, o.e_min, o.e_max, &envelope);
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
  fmt::print("iteration {} ({} terms, J {:.6g}), input '{}' in [{}, {}] V, {} ->{}{}\n", k,
             it.terms.size(), it.j, o.input, o.e_min, o.e_max,
             envelope ? "operating envelope" : "no envelope (model file predates it)",
             o.table.empty() ? "" : " " + o.table, o.header.empty() ? "" : " " + o.header);
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
  cmd->add_option("--e-min", o->e_min, "Lowest admissible command [V]")
      ->check(mrd::cli::Finite)
      ->capture_default_str();
  cmd->add_option("--e-max", o->e_max, "Highest admissible command [V]")
      ->check(mrd::cli::Finite)
      ->capture_default_str();
  cmd->callback([o] { RunExport(*o); });
}

}  // namespace mrd::host::cli
