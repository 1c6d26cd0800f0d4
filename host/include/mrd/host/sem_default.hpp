#pragma once
// `mrd identify` without --spec (and Python's identify with spec=None): every built-in spec
// (default_spec.hpp) is identified on the data (IdentifyFamilies, sem_family.hpp) and the one
// whose selected model best predicts data it was not fitted on is kept:
//   - with validation data: the lowest free-run RMSE of the selected model over the
//     validation sets;
//   - without: the lowest kSelectionFolds-fold cross-validated free-run RMSE of the selected
//     structure inside the identification data (CrossValidatedCost, sem.hpp: coefficients by
//     least squares on the other folds); records too short for that many folds fall back to
//     the identification RMSE.
// Both in the output's unit with every row weighted alike (the specs' own cost weightings
// differ, so their J do not compare), so a spec fitted with a relative weighting and one with
// MSE are judged on one scale. Ties (and non-finite scores) keep the earlier spec.

#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>
#include <vector>

#include "mrd/host/csv.hpp"
#include "mrd/host/sem.hpp"
#include "mrd/host/sem_family.hpp"

namespace mrd::host {

struct SpecCandidate {
  std::string name;       // BuiltInSpec::name
  double rmse = 0.0;      // by SpecChoice::rule [output unit]; +inf when not finite
  int selected = 0;       // the iteration its own selection picked
  std::size_t terms = 0;  // of that iteration
};

struct SpecChoice {
  std::vector<SpecCandidate> specs;  // BuiltInSemSpecs() order
  int chosen = -1;                   // index into specs
  std::string rule;                  // how rmse was computed, in words
  bool empty() const { return specs.empty(); }
};

struct DefaultIdentification {
  FamilyIdentification identification;  // of the chosen spec
  SpecChoice choice;
};

// Called when a built-in spec starts (index, count, name) and after it was scored.
using SpecProgress = std::function<void(std::size_t, std::size_t, const SpecCandidate&, bool done)>;
// The progress line of built-in spec i of n (no newline), as `mrd identify` and Python's identify
// report it: as it starts "built-in spec 1/3: NAME", when done with its selected iteration,
// terms and RMSE.
std::string SpecProgressLine(std::size_t i, std::size_t n, const SpecCandidate& c, bool done);

// The choice above. Throws what IdentifyFamilies throws (a data set without the specs'
// columns: InputError naming the first spec).
DefaultIdentification IdentifyDefault(std::span<const DataSet> identification,
                                      std::span<const DataSet> validation,
                                      const SemOptions& options, const FamilyProgress& member = {},
                                      const SpecProgress& progress = {});

// Model file section "spec_choice" (model_file.hpp):
//   {"rule": "...", "chosen": 1, "specs": [{"name": "...", "rmse": 41.2, "selected": 12,
//    "terms": 10}, ...]}
// rmse is null when not finite. SpecChoiceFromJson throws InputError naming `path` for a missing
// or mistyped field or a chosen index out of range.
nlohmann::json SpecChoiceToJson(const SpecChoice& c);
SpecChoice SpecChoiceFromJson(const nlohmann::json& j, const std::string& path);

}  // namespace mrd::host
