#pragma once
// Transform families (spec key 'family', candidate_spec.hpp; docs/design.md §5): instead of a
// hand-picked transform, a regressor offers a few (e.g. |v|^0.2, |v|^0.5, tanh(v/0.1)) and the
// engine identifies once per combination of members over all family regressors (at most
// kMaxFamilyCombinations), then keeps the combination whose selected model scores best by
// the selection's own criterion:
//   - with validation data: the summed validation J of the selected iteration;
//   - without: CrossValidationScore (sem.hpp) of the selected iteration: its summed
//     kSelectionFolds-fold cross-validated free-run J (the one its selection computed, the
//     same folds for every member) with the extended-BIC penalty of SelectByCrossValidation
//     on n scored samples, so a member does not win by a spurious extra term; or, when the
//     records are too short for that many folds, the selected iteration's identification J.
// Ties (and non-finite scores) go to the earlier combination. The chosen spec has the
// family replaced by the chosen member, so the model file, `mrd simulate`, `mrd export` and
// the firmware see an ordinary fixed transform.

#include <cstddef>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/sem.hpp"

namespace mrd::host {

// One identification of the family search.
struct FamilyCombination {
  std::vector<TransformChoice> members;  // one per FamilyResult::regressors entry
  double score = 0.0;                    // by FamilyResult::rule; +inf when not finite
  int selected = 0;                      // iteration picked by this run's own selection
  std::size_t terms = 0;                 // of that iteration
  double j = 0.0;                        // identification J of that iteration
};

struct FamilyResult {
  std::vector<std::string> regressors;          // family regressors by name, spec order
  std::vector<FamilyCombination> combinations;  // FamilyCombinations order
  int chosen = -1;                              // index into combinations
  std::string rule;                             // how `score` was computed, in words
  bool empty() const { return regressors.empty(); }
};

// Every combination of members, the first family regressor varying slowest; one empty
// combination when the spec has no family.
std::vector<std::vector<TransformChoice>> FamilyCombinations(const SemSpec& spec);

// The spec with the i-th family regressor fixed to choice[i] and every family cleared.
SemSpec ResolveFamilies(const SemSpec& spec, const std::vector<TransformChoice>& choice);

struct FamilyIdentification {
  SemSpec spec;         // resolved to the chosen combination (the spec itself without family)
  SemResult result;     // identification of the chosen combination
  FamilyResult family;  // empty when the spec has no family
};

// Called after each combination's identification: index (0-based), count, its record.
using FamilyProgress =
    std::function<void(std::size_t, std::size_t, const std::vector<std::string>& regressors,
                       const FamilyCombination&)>;

// Identify (sem.hpp) once per combination (options.progress is called for every run's
// iterations), then the choice above. Without a family: one Identify, empty family. Throws
// what Identify throws.
FamilyIdentification IdentifyFamilies(const SemSpec& spec, std::span<const DataSet> identification,
                                      std::span<const DataSet> validation,
                                      const SemOptions& options,
                                      const FamilyProgress& progress = {});

// "abs_pow(exponent=0.2)", "sign".
std::string TransformLabel(const TransformChoice& c);
// "u2 = abs_pow(exponent=0.2), w = sign": the members of a combination by regressor.
std::string FamilyMembers(const std::vector<std::string>& regressors, const FamilyCombination& c);
// The progress line of combination i of n after its identification (no newline), as
// `mrd identify` and Python's identify report it: "family 2/4: u2 = sign: selected iteration 9
// (7 terms, J 0.0123), score -812".
std::string FamilyProgressLine(std::size_t i, std::size_t n,
                               const std::vector<std::string>& regressors,
                               const FamilyCombination& c);

// Model file section "family" (model_file.hpp):
//   {"regressors": ["u2"], "rule": "...", "chosen": 1,
//    "combinations": [{"members": [{"transform": "abs_pow", "exponent": 0.2}], "score": ...,
//                      "selected": 7, "terms": 9, "J": ...}, ...]}
// score and J are null when not finite. FamilyFromJson throws InputError naming `path` for a
// missing or mistyped field, an unknown transform, a member count that does not match the
// regressors, a chosen index out of range, or a chosen member that is not what the (resolved)
// spec holds.
nlohmann::json FamilyToJson(const FamilyResult& f);
FamilyResult FamilyFromJson(const nlohmann::json& j, const SemSpec& spec, const std::string& path);

}  // namespace mrd::host
