#pragma once
// `mrd report`: PNG plots (gnuplot) and a text summary of an identified model on data files.
//
// For every data file: the free-run simulation of the reported iteration (SimulateModel, the
// code path of `mrd simulate`), plotted against the data as force-displacement and
// force-velocity loops (a loop is skipped, with a note, when the file has no `x` / `v`
// column) and as time series with the error; the cost J of every iteration of the model on
// the file; the residual correlations (residuals.hpp, <stem>_residuals.png) and the range
// check of the inputs (model_judge.hpp; warnings also through progress). For the model: J per
// iteration (identification, each validation set of the model file, each data file) on a log axis
// with the selected iteration marked. The summary lists the model's terms and coefficients, per
// data file J, MSE, RMSE, RRSE and fit %, the J per iteration table, notes (skipped plots, diverged
// iterations) and the files written.
//
// Output directory: every input is read and checked first (model file, iteration, data files
// and the signals the model needs: InputError, nothing written). The files are then built in
// a temporary directory beside DIR (".DIR.report-XXXXXX"); at the end that directory is
// renamed to DIR when DIR does not exist or is empty, otherwise each file is renamed into DIR
// (each one atomic; other files already in DIR are left alone). On failure the temporary
// directory is removed.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mrd/common/time_window.hpp"

namespace mrd::host {

struct ReportOptions {
  std::string model;                 // model file (JSON) from `mrd identify`
  std::vector<std::string> data;     // data files (CSV), at least one
  std::string out_dir;               // output directory; its parent must exist
  std::optional<int> iteration;      // iteration to report (unset: the model's selected one)
  int max_lag = 50;                  // residual correlations up to this lag [samples]
  std::optional<TimeWindow> window;  // time plots: drawn sample by sample (default: first 5 s)
  std::function<void(const std::string&)> progress;  // one line per step, no newline
};

struct ReportResult {
  std::string summary;             // text of summary.txt
  std::vector<std::string> files;  // files written (paths under out_dir), summary.txt last
};

// Writes the report. Throws InputError for bad input (unreadable or malformed model or data
// file, a data file lacking a signal of the model or too short, an iteration not in the model
// file, an --out path that is not a directory or has no parent directory) before anything is
// written; std::runtime_error when gnuplot is missing (also before anything is written) or
// fails, or on an I/O error.
ReportResult WriteReport(const ReportOptions& options);

// Axis label of a signal with its unit for the toolkit's signals ("x [cm]", "v [cm/s]",
// "f [N]", "E [V]", "t [s]"); the bare name for others.
std::string SignalLabel(const std::string& name);

}  // namespace mrd::host
