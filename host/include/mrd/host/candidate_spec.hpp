#pragma once
// Candidate spec of the SEM identification (docs/design.md §4, §5): which elementary regressors
// (a named transform of one signal, at a set of delays, raised to a set of powers) build the
// candidate terms, the limits on terms, the cost weighting and the algorithm settings.
// Works for any CSV columns.
// Every key with its meaning, default and cost, and a complete example: docs/spec.md.
//
// Errors (unknown key, wrong type, bad power or delay, unknown transform, duplicate name,
// empty candidate set, malformed TOML; a family that is empty, repeats a member, has a bad
// member, sits on the output signal, comes with 'transform' or its parameter, or makes more
// than kMaxFamilyCombinations combinations) throw InputError naming the file and line.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mrd/common/model.hpp"

namespace mrd::host {

// One member of a transform family: a transform and its parameter (ElementaryRegressor's
// `exponent` meaning).
struct TransformChoice {
  Transform transform = Transform::kIdentity;
  double parameter = 1.0;
  std::size_t line = 0;  // line of the member in the spec file, for messages
  friend bool operator==(const TransformChoice& a, const TransformChoice& b) {
    return a.transform == b.transform && a.parameter == b.parameter;
  }
};

// Most combinations of family members over all family regressors of a spec (one full
// identification each).
inline constexpr std::size_t kMaxFamilyCombinations = 16;

struct ElementaryRegressor {
  std::string name;
  std::string signal;
  Transform transform = Transform::kIdentity;
  double exponent = 1.0;        // abs_pow: the exponent; low_pass: tau [samples]; tanh: scale;
                                // clip: limit (normalised units)
  std::vector<int> powers;      // sorted, unique, 1 ... kMaxPower
  std::vector<int> delays;      // sorted, unique, 0 ... kMaxDelay [samples]
  std::size_t line = 0;         // line of [[regressor]] in the spec file, for messages
  std::size_t signal_line = 0;  // line of its 'signal' key
  // Transforms to choose among (spec key 'family'; empty: `transform` is fixed). While
  // unresolved, transform/exponent hold the first member; ResolveFamilies (sem_family.hpp)
  // fixes one member and clears this.
  std::vector<TransformChoice> family;
};

enum class CostWeighting { kRelative, kMse };
enum class Strategy { kBest, kFirst };
// Automatic model pick without validation data (sem.hpp: SelectByCrossValidation,
// SelectIteration).
enum class Selection { kCrossValidation, kTolerance };
// Where the cross-validated pick takes the noise to enter (sem.hpp, SelectByCrossValidation):
// at the output (score: free-run error), in the equation (score: one-step prediction error),
// or auto: equation when the lowest-J iteration's free-run residual is coloured and its one-step
// residual is the whiter, at least half unpredictable (sem.hpp, kEquationNoiseShare), else output.
enum class SelectionNoise { kAuto, kOutput, kEquation };

// Stress check of the search ([stress]; host/include/mrd/host/sem_stress.hpp).
struct StressSpec {
  bool enabled = false;                      // a [stress] table is present
  double stretch = 2.0;                      // factor on stretch_signals (>= 1)
  std::vector<std::string> stretch_signals;  // empty: every input signal not swept
  std::vector<std::string> sweep_signals;    // triangle over [min, max] of the data
  int sweep_period = 2000;                   // [samples]
  int hold = 1000;                           // [samples] of held inputs after each record
  int rest = 3000;                           // [samples] of each at-rest record; 0: none
  double force_bound = 3.0;                  // |output| bound / largest |output| in the data
  std::size_t line = 0;                      // line of [stress], for messages
};

// Default of SemSpec::max_candidates: ~100x the paper spec's 1551, a few hundred MB at most.
inline constexpr std::int64_t kDefaultMaxCandidates = 200000;

struct SemSpec {
  std::string path;  // source file, for messages ("" when built in code)
  std::string output;
  std::size_t output_line = 0;  // line of the 'output' key
  std::vector<ElementaryRegressor> regressors;
  // Limits on candidate terms.
  int max_factors = 3;    // most elementary factors (distinct regressor/delay pairs) per term
  int max_degree = 0;     // most summed powers per term; 0: no limit
  bool constant = false;  // the constant term is a candidate
  // Most candidate combinations (counted before any is built, duplicates included); a larger
  // set is refused with its count ([limits] max_candidates, mrd identify --max-candidates).
  std::int64_t max_candidates = kDefaultMaxCandidates;
  // Cost J = sum over data sets of (1/N) sum_k w_k (y_k - ysim_k)^2 on normalised signals,
  // w_k = 1/max(|y_k|, floor) (relative) or 1 (mse).
  CostWeighting weighting = CostWeighting::kRelative;
  double floor = 0.1;
  // Algorithm.
  Strategy strategy = Strategy::kFirst;  // default chosen on the recovery suite (issue 15)
  double threshold_percent = 2.0;        // least relative decrease of J to accept a candidate [%]
  int max_iterations = 20;
  double target_j = 0.0;          // stop once J <= target_j
  double divergence_limit = 1e3;  // |normalised ysim| above this rejects a candidate
  // Model pick without validation data: cross-validation of the free-run cost inside the
  // identification data (default) or the tolerance rule on the identification J.
  Selection selection = Selection::kCrossValidation;
  double selection_tolerance_percent = 5.0;                // tolerance rule, see SelectIteration
  SelectionNoise selection_noise = SelectionNoise::kAuto;  // cross-validation: its score
  bool drop_terms = true;      // cross-validation: terms of the pick dropped while it scores lower
  bool score_exchange = true;  // cross-validation: terms of the pick exchanged likewise
  bool exchange = true;        // exchange moves after add and prune (sem.hpp)
  bool one_step_start = true;  // second search path from the one-step forward regression
  bool refine = true;          // output-error refinement of every iteration's coefficients
  std::vector<std::string> initial;  // initial structure, term strings
  // Invertibility required of every model the search accepts ([algorithm] monotone_in, ""
  // off): the force rises with this input signal (the command) in the dissipative direction
  // (sign of signal "v", when the spec has it) and is one-to-one in it, over the
  // identification envelope (host/include/mrd/host/invertibility.hpp).
  std::string monotone_in;
  std::size_t monotone_line = 0;  // line of the key, for messages
  StressSpec stress;

  // Index of a regressor by name, or -1.
  int RegressorIndex(const std::string& name) const;
  // Largest delay of any regressor [samples]: the first this-many samples of every data set
  // seed the simulation with measured values and are not scored.
  int MaxDelay() const;
  // Signals used (output first, then regressor signals in first-use order).
  std::vector<std::string> Signals() const;
};

// Reads and validates a spec file. Throws InputError (file, line, reason).
SemSpec LoadSemSpec(const std::string& path);
// Parses spec text (path is used in messages only).
SemSpec ParseSemSpec(const std::string& text, const std::string& path);

// One factor of a term: regressor(k - delay)^power.
struct SemFactor {
  int regressor = 0;
  int delay = 0;
  int power = 1;
  friend bool operator==(const SemFactor&, const SemFactor&) = default;
};

// Product of factors, sorted by (regressor, delay), each pair at most once. Empty: constant.
struct SemTerm {
  std::vector<SemFactor> factors;
  friend bool operator==(const SemTerm&, const SemTerm&) = default;
};

// "y(k-1)^2*u2(k)"; "1" for the constant.
std::string TermName(const SemSpec& spec, const SemTerm& term);
// Parses TermName's syntax (spaces allowed; power 1 may be omitted). Throws InputError with
// `file`/`line` for an unknown regressor, a delay or power not offered by the spec, or bad
// syntax. The result is canonical (sorted, equal pairs merged).
SemTerm ParseTerm(const SemSpec& spec, const std::string& text, const std::string& file = "",
                  std::size_t line = 0);

// Algebraic identity key of a term: per (signal, delay), the sign parity and the exponent of
// |s|. Two terms with equal keys are the same function (sign^2 = 1, |s|^a|s|^b = |s|^(a+b),
// s = sign(s)|s|).
std::string TermKey(const SemSpec& spec, const SemTerm& term);

// Candidate terms in generation order (fewer factors first, then regressor/delay/power order),
// skipping terms algebraically identical to an earlier one (TermKey) and terms that reduce to
// the constant when the constant is not offered. Throws InputError when the set is empty or
// CountCandidateCombinations exceeds spec.max_candidates (checked before anything is built).
std::vector<SemTerm> GenerateCandidates(const SemSpec& spec);

// Number of factor combinations the limits allow (before removing algebraic duplicates),
// counted without building them; saturates at 2^62.
std::int64_t CountCandidateCombinations(const SemSpec& spec);

}  // namespace mrd::host
