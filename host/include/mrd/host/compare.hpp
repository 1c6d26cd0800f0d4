#pragma once
// `mrd compare`: several models on several data files, one table. Per model x data file the
// free-run simulation (SimulateModel, the code path of `mrd simulate`) of the model's selected
// iteration: fit %, RMSE in the output's unit, NRMSE (= ||y - ysim|| / ||y - mean y||, no
// weighting), J with its weighting, terms, diverged; the envelope check of the inputs
// (model_judge.hpp) and the invertibility in the command (invertibility.hpp: the share of
// states where the force falls as E rises or turns back, on the data and the envelope grid). With
// an output directory: the table (compare.txt, compare.json) and per data file an overlay plot of
// the measured output and every model's free run
// (<stem>_compare.png), written through a staging directory (staging_dir.hpp).

#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "mrd/common/time_window.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/model_judge.hpp"

namespace mrd::host {

struct CompareOptions {
  std::vector<std::string> models;                   // model files (JSON), at least one
  std::vector<std::string> data;                     // data files (CSV), at least one
  std::string out_dir;                               // "" : no files, table on stdout only
  std::optional<TimeWindow> window;                  // plots: the window (default: first 5 s)
  std::function<void(const std::string&)> progress;  // one line per step
};

struct CompareRow {
  std::string model, data;  // paths as given
  int iteration = 0;
  std::size_t terms = 0;
  SimMetrics metrics;
  std::string weighting;  // CostWeightingShort of the model
  std::string unit;       // output unit ("N"), may be ""
  std::vector<EnvelopeCheck> envelope;
  // Invertibility in the model's command on the states of this data file and the model's
  // envelope grid (invertibility.hpp); failing share [%], -1 when the model has no command.
  double invertibility_fail_percent = -1.0;
  nlohmann::json invertibility;
};

struct CompareResult {
  std::vector<CompareRow> rows;       // model-major: every file of model 1, then model 2 ...
  std::string table;                  // text of compare.txt
  nlohmann::json json;                // compare.json
  std::vector<std::string> warnings;  // envelope and invertibility warnings, one line each
  std::vector<std::string> files;     // written (under out_dir)
};

// Reads every model and data file first (InputError naming the file and the reason, nothing
// written); a data file must hold the signals of every model. std::runtime_error when gnuplot
// is missing (with --out) or on an I/O error.
CompareResult CompareModels(const CompareOptions& options);

}  // namespace mrd::host
