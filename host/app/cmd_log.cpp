// mrd log: describe, export and plot the firmware's per-period log (host/run_log.hpp).
#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/run_log.hpp"

namespace mrd::host::cli {
namespace {

struct LogOptions {
  std::string file;
  std::string csv;
  std::vector<std::string> fields;
  std::string out_dir;
  std::string window;  // --window FROM:TO [s]; "": the first 5 s
};

// A note on a truncated tail (the log is still read) on stderr.
void Note(const runlog::Log& log, const std::string& path) {
  if (log.damage == runlog::Damage::kTruncated) {
    fmt::print(stderr, "note: {}\n", RunLogDamageNote(log, path));
  }
}

void Info(const LogOptions& o) {
  // A corrupt block: what came before it is shown, then the error (exit 2).
  const runlog::Log log = LoadRunLog(o.file, /*allow_corrupt=*/true);
  fmt::print("{}", RunLogInfo(log, o.file));
  if (log.damage == runlog::Damage::kCorrupt)
    throw InputError("", 0, RunLogDamageNote(log, o.file));
  Note(log, o.file);
}

void Export(const LogOptions& o) {
  CheckOutputPath(o.csv);
  const runlog::Log log = LoadRunLog(o.file);
  Note(log, o.file);
  const std::string csv = RunLogCsv(log, o.fields);
  WriteFileAtomic(o.csv, csv);
  fmt::print(stderr, "log: wrote {} ({} records)\n", o.csv, log.num_records);
}

void Plot(const LogOptions& o) {
  TimeWindow window;
  std::string why;
  if (!o.window.empty() && !ParseTimeWindow(o.window, &window, &why)) {
    throw InputError("", 0, "--window " + why);
  }
  const runlog::Log log = LoadRunLog(o.file);
  Note(log, o.file);
  const TimeWindow* asked = o.window.empty() ? nullptr : &window;
  const std::string png = PlotRunLog(log, o.file, o.out_dir, asked, [](const std::string& line) {
    fmt::print(stderr, "{}\n", line);
    std::fflush(stderr);
  });
  fmt::print("{}\n", png);
}

}  // namespace

void RegisterLog(CLI::App& app) {
  auto o = std::make_shared<LogOptions>();
  CLI::App* cmd = app.add_subcommand(
      "log",
      "Read the firmware's per-period log (mrd-firmware --log FILE, [log] in its config): "
      "info, export to CSV, plot.");
  cmd->require_subcommand(1);
  cmd->footer(
      "A file cut inside its last block (power cut, kill -9) is read up to its last whole "
      "block, with a note on stderr. Not a log, another format version, a damaged header, a "
      "corrupt block (info: shown up to it) or an unknown field: error, exit 2. Format and "
      "fields: docs/logging.md.");
  CLI::App* info = cmd->add_subcommand(
      "info",
      "Format version, source, period, records, blocks, time span, dropped records, "
      "damage, and every field with its type and unit.");
  info->add_option("FILE", o->file, "Log file")->required();
  info->callback([o] { Info(*o); });
  CLI::App* exp = cmd->add_subcommand(
      "export",
      "Write the records as CSV (header row of field names; integers exact, floats "
      "shortest round-trip, nan for none); the file is written atomically.");
  exp->add_option("FILE", o->file, "Log file")->required();
  exp->add_option("--csv", o->csv, "Output CSV file")->required();
  exp->add_option("--fields", o->fields, "Fields to export, comma separated (default: all)")
      ->delimiter(',');
  exp->callback([o] { Export(*o); });
  CLI::App* plot = cmd->add_subcommand(
      "plot",
      "DIR/<stem>_time.png: force (model, demand, measured), command and the law's E, "
      "safe state and watchdog causes over a window of a few seconds (sample by sample, the "
      "safe state shaded), and an overview of the whole log (envelopes) below (gnuplot).");
  plot->add_option("FILE", o->file, "Log file")->required();
  plot->add_option("--out", o->out_dir, "Output directory (created; its parent must exist)")
      ->required();
  plot->add_option("--window", o->window,
                   "Time window drawn sample by sample, FROM:TO [s from the first record] "
                   "(default: the first 5 s)");
  plot->callback([o] { Plot(*o); });
}

}  // namespace mrd::host::cli
