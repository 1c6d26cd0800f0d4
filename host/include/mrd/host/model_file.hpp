#pragma once
// Model file (JSON) written by `mrd identify`, read by `mrd simulate` and `mrd export`:
//
//   { "format": "mrd-sem-model", "version": 1,
//     "spec": { ...the candidate spec... },
//     "channels": [{"name": "f", "offset": 0, "scale": 1234.5,          // output first
//                   "min": -1200, "max": 1234.5}, ...],   // envelope: range of the
//                                                          // identification data (optional)
//     "warmup_samples": 1,        // leading samples that seed a simulation (spec max delay)
//     "iterations": [{"iteration": k, "J": ..., "validation_J": [...], "elapsed_s": ...,
//                     "stress": {"pass": true, "peak": 1.2, "reason": "",   // spec [stress] only
//                                "rejected_candidates": 3},
//                     "monotone": {"pass": true, "states": n, "failing": 0,  // monotone_in only
//                                  "share_percent": 0, "worst": "...", "rejected_candidates": 2},
//                     "terms": [{"coefficient": c,
//                                "factors": [{"regressor": "u2", "delay": 1, "power": 3}]}]}],
//     "selected": k, "selection_rule": "...",
//     "identification_data": ["id.csv"], "validation_data": ["v1.csv", ...],  // optional
//     "family": {...},    // spec with a transform family only: every member's score and the
//                         // choice (sem_family.hpp); "spec" then holds the chosen transform
//     "invertibility": {"iteration": k, "input": "E", "e_min": 0, "e_max": 2.25,
//                       "states": n, "failing": 0, "share_percent": 0, "summary": "..."},
//     "spec_choice": {...} }  // no --spec: every built-in spec's score and the choice
//                             // (sem_default.hpp); "spec" then holds the chosen spec
//
// Coefficients are in normalised units (signals divided by their channel scale).

#include <string>
#include <vector>

#include "mrd/common/model.hpp"
#include "mrd/common/table.hpp"
#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/sem.hpp"
#include "mrd/host/sem_default.hpp"
#include "mrd/host/sem_family.hpp"

namespace mrd::host {

// Invertibility of the selected iteration as `mrd identify` checked it (invertibility.hpp):
// over the identification data and the envelope grid, the command over its envelope.
struct InvertibilityRecord {
  bool recorded = false;  // false: a model file written before it was recorded
  int iteration = 0;
  std::string input;                // the command, e.g. "E"
  double e_min = 0.0, e_max = 0.0;  // range checked [V]
  std::size_t states = 0, failing = 0;
  double share_percent = 0.0;  // failing / states [%]
  std::string summary;         // InvertibilitySummary, in words
};

struct ModelFile {
  std::string path;  // source file, for messages ("" when built in memory)
  SemSpec spec;
  std::vector<ChannelInfo> channels;  // channels[0] is the output
  std::vector<SemIteration> iterations;
  int selected = 0;
  std::string selection_rule;
  std::size_t num_candidates = 0;
  // Data files of the run, as given on the command line (provenance; may be empty).
  std::vector<std::string> identification_data;
  std::vector<std::string> validation_data;  // in the order of validation_J
  FamilyResult family;  // transform family search (empty: the spec had no family)
  InvertibilityRecord invertibility;
  SpecChoice spec_choice;  // mrd identify without --spec: the built-in specs (empty: --spec)

  int warmup_samples() const { return spec.MaxDelay(); }
  // Iteration by its number; throws InputError naming the file when absent.
  const SemIteration& Iteration(int k) const;
};

// Builds the model file of an identification run.
ModelFile MakeModelFile(const SemSpec& spec, const SemResult& result);

// JSON text / file. Save writes atomically. Load throws InputError (file, reason) on
// unreadable or malformed JSON, a missing or mistyped key, a bad spec, or a term that names
// an unknown regressor.
std::string ModelFileToJson(const ModelFile& m);
void SaveModelFile(const ModelFile& m, const std::string& path);
ModelFile LoadModelFile(const std::string& path);

// The fixed-size runtime model of one iteration (channels and regressors limited to those
// the terms use, output first). Throws InputError with the reason when the model exceeds a
// capacity of common/model.hpp (terms, factors per term, channels, regressors, delay, power,
// channel-name length) or does not validate; never truncates.
mrd::Model ToRuntimeModel(const ModelFile& m, int iteration);

// Free-run simulation of one iteration on a data set through mrd::ModelRunner (the same
// evaluator as the firmware): the first warmup_samples() rows seed the history with measured
// values; the rest are simulated and scored. Throws InputError for a missing column.
struct SimMetrics {
  double j = 0.0;              // cost of the spec's weighting, normalised signals
  double mse = 0.0;            // normalised
  double mse_physical = 0.0;   // output units squared
  double rmse_physical = 0.0;  // output units
  double rrse = 0.0;           // ||y - ysim|| / ||y - mean(y)||
  double fit_percent = 0.0;    // 100 (1 - rrse)
  std::size_t samples = 0;     // scored samples
  bool diverged = false;       // non-finite or |ysim| beyond the divergence limit
};
SimMetrics SimulateModel(const ModelFile& m, int iteration, const DataSet& data,
                         std::vector<double>* ysim_raw = nullptr);

}  // namespace mrd::host
