// mrd import: foreign CSV (bench rigs, published data) -> toolkit data file t,x,v,E,f.
#include <fmt/format.h>

#include <chrono>
#include <memory>
#include <string>

#include "commands.hpp"
#include "mrd/common/cli_checks.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/import.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host::cli {
namespace {

struct ImportFlags {
  ImportOptions options;
  std::string map;
  std::string scale;
  std::string separator = ",";
  std::string out;
};

void RunImport(ImportFlags& f) {
  const auto start = std::chrono::steady_clock::now();
  CheckOutputPath(f.out);
  f.options.map = ParseImportMap(f.map);
  if (!f.scale.empty()) f.options.scale = ParseImportScale(f.scale);
  if (f.separator == "tab" || f.separator == "\\t") f.separator = "\t";
  if (f.separator.size() != 1) {
    throw InputError("", 0, fmt::format("--separator '{}': one character or 'tab'", f.separator));
  }
  f.options.separator = f.separator[0];
  const ImportResult r = Import(f.options);
  WriteCsv(f.out, r.names, r.columns);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fmt::print("{}  wrote {} ({} rows, {}) in {:.2f} s\n", FormatImportReport(r.report), f.out,
             r.report.rows_written, fmt::join(r.names, ","), seconds);
}

}  // namespace

void RegisterImport(CLI::App& app) {
  auto f = std::make_shared<ImportFlags>();
  ImportOptions& o = f->options;
  CLI::App* cmd = app.add_subcommand(
      "import",
      "Import a foreign CSV (quoted header, trailing separators, sparse metadata columns, an "
      "incomplete last row are repaired and reported): map and scale columns to t,x,v,E,f, "
      "optionally derive v from x, resample through an anti-aliasing filter; write CSV.");
  cmd->add_option("--in", o.in_path, "Input CSV file")->required();
  cmd->add_option("--map", f->map,
                  "Output name = input column, comma-separated, e.g. t=t,x=D,v=V,E=Y,f=F; needs "
                  "t,x,v,E,f (v unless --derive-velocity); other names become extra columns")
      ->required();
  cmd->add_option("--scale", f->scale,
                  "Output name = factor, e.g. x=0.1,f=1000 (applied after mapping; on x before "
                  "differentiation)");
  cmd->add_option("--rate", o.out_rate_hz, "Output sampling rate [Hz]")
      ->check(mrd::cli::Finite)
      ->capture_default_str();
  cmd->add_flag("--derive-velocity", o.derive_velocity,
                "v = d/dt x by a zero-phase Kaiser low-pass (-6 dB at --cutoff) and central "
                "differences, at the input rate");
  cmd->add_option("--cutoff", o.velocity_cutoff_hz,
                  "Cut-off of the velocity differentiator [Hz] (-6 dB; pass band to 0.75x, stop "
                  "band from 1.25x, 60 dB)")
      ->check(mrd::cli::Finite)
      ->capture_default_str();
  cmd->add_option("--max-jitter", o.max_jitter,
                  "Time deviation from the uniform grid allowed beyond the printed rounding of "
                  "t [sampling periods]")
      ->check(mrd::cli::Finite)
      ->capture_default_str();
  cmd->add_option("--rate-column", o.rate_column,
                  "Column stating the sampling rate, cross-checked against t to 0.1 % ('' for "
                  "none)")
      ->capture_default_str();
  cmd->add_option("--separator", f->separator, "Field separator: one character or 'tab'")
      ->capture_default_str();
  cmd->add_option("--out", f->out, "Output CSV file (t,x,v,E,f + extra mapped columns)")
      ->required();
  cmd->callback([f] { RunImport(*f); });
}

}  // namespace mrd::host::cli
