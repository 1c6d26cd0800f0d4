#pragma once
// SEM identification engine (docs/design.md §5): parameters by least squares on the one-step
// regression (measured output in the regressors), structure by the free-run simulation cost
//
//   J = sum over data sets d of (1/N_d) sum_k w_k (y(k) - ysim(k))^2,
//   w_k = 1/max(|y(k)|, floor) (relative weighting) or 1 (mse), normalised signals,
//
// scored from sample k = spec.MaxDelay() on (earlier samples seed the simulation with
// measured values). Per major iteration: try adding every candidate (bordered LS update from
// kept Gram products, free-run simulation with early stop), accept the best (best
// improvement), or the first in one-step-criterion rank order that lowers J by
// threshold_percent (first improvement; the best when none does); then prune: repeatedly
// drop the term whose removal gives the lowest J while that J is still below the previous
// major iteration's. Stops at target_j, max_iterations, or when no candidate is admissible.
// A candidate whose simulation is non-finite or leaves |y| <= divergence_limit is rejected.
// Results do not depend on the thread count (ties broken by candidate index).

#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/csv.hpp"

namespace mrd::host {

struct ChannelInfo {
  std::string name;
  double offset = 0.0;
  double scale = 1.0;  // normalised = (raw - offset) / scale
  // Operating envelope: range of the identification data [raw units] (has_range false in
  // model files written before it was recorded).
  bool has_range = false;
  double min = 0.0;
  double max = 0.0;
};

// Stress check verdict of one model (host/include/mrd/host/sem_stress.hpp).
struct StressVerdict {
  bool checked = false;  // the spec has [stress]
  bool pass = true;
  double peak = 0.0;   // largest |simulated output| on the stress input / largest |output|
                       // of the data (+inf: diverged)
  std::string reason;  // why it failed ("" when it passed)
};

// Invertibility verdict of one model in the spec's monotone_in command (spec [algorithm]
// monotone_in; host/include/mrd/host/invertibility.hpp): the search's states (every s-th sample
// the identification data visited, s = ceil(rows / kGateVisitedStates), and the envelope grid).
inline constexpr std::size_t kGateVisitedStates = 50000;
struct MonotoneVerdict {
  bool checked = false;  // the spec sets monotone_in
  bool pass = true;
  std::size_t states = 0;
  std::size_t failing = 0;
  double share_percent = 0.0;  // failing / states [%]
  std::string worst;           // the state of the lowest df/dE * sign(v), in words
};

struct SemIteration {
  int iteration = 0;  // 0: initial structure (possibly empty)
  std::vector<SemTerm> terms;
  std::vector<double> coefficients;  // normalised units
  double j = 0.0;                    // identification cost
  std::vector<double> validation_j;  // one per validation data set
  std::vector<double> cv_j;          // per fold: cross-validated cost as the selection by
                                     // cross-validation scored it (free-run J, prefiltered, or
                                     // one-step J: SemResult::cv_one_step); empty: did not run
  double elapsed_s = 0.0;            // since the start of Identify
  int rejected = 0;         // candidates of this iteration's search rejected: diverging free run
                            // (non-finite or beyond divergence_limit) or linearly dependent column
  int stress_rejected = 0;  // of them, candidates that failed the stress check
  StressVerdict stress;     // of this iteration's model
  int monotone_rejected = 0;  // candidates whose model broke monotone_in (spec)
  MonotoneVerdict monotone;   // of this iteration's model
};

// An iteration the selection never picks: it failed the stress check or monotone_in.
inline bool FailsChecks(const SemIteration& it) {
  return (it.stress.checked && !it.stress.pass) || (it.monotone.checked && !it.monotone.pass);
}

// Fewest scored samples (rows after the largest delay, over all identification files) per
// model parameter: a term is only added while the model keeps at least this many.
inline constexpr std::size_t kMinSamplesPerParameter = 10;

struct SemOptions {
  // Overrides of the spec's algorithm settings (unset: the spec's value).
  std::optional<Strategy> strategy;
  std::optional<double> threshold_percent;
  std::optional<int> max_iterations;
  std::optional<double> target_j;
  std::optional<std::vector<std::string>> initial;    // term strings
  std::optional<std::int64_t> max_candidates;         // overrides [limits] max_candidates
  int threads = 1;                                    // worker threads (>= 1)
  std::function<void(const SemIteration&)> progress;  // called after every iteration
};

struct SemResult {
  std::vector<ChannelInfo> channels;  // spec.Signals() order; channels[0] is the output
  std::vector<SemIteration> iterations;
  int selected = 0;            // iteration picked automatically (SelectModel)
  std::string selection_rule;  // how `selected` was picked, in words
  bool cv_one_step = false;    // the cross-validated pick scored the one-step prediction error
                               // (noise in the equation: spec selection_noise), not the free run
  std::size_t num_candidates = 0;
  bool fast_path = false;       // free run by the y(k-1) polynomial recursion
  int exhausted_rejected = -1;  // >= 0: the search stopped because all candidates
                                // were rejected (this many)
  // What the search's extras cost (wall time [s], for the progress output only): the first
  // path without its exchange moves, the exchange moves of every path (spec `exchange`), the
  // second start's path (spec `one_step_start`; -1: not run) and its start's size, which is
  // at most the largest model of the first path (so it cannot cost more per step).
  double path_s = 0.0;
  double exchange_s = 0.0;
  double second_start_s = -1.0;
  std::size_t second_start_terms = 0;
};

// Normalisation: offset 0, scale = max |s| over all identification data (1 when all zero).
std::vector<ChannelInfo> ComputeScales(const SemSpec& spec, std::span<const DataSet> data);

// Runs the identification. Throws InputError when a data set lacks a spec signal (naming the
// spec file and the regressor's line) or is too short, or an initial term is bad. A transform
// family runs as its first member; IdentifyFamilies (sem_family.hpp) chooses among them.
SemResult Identify(const SemSpec& spec, std::span<const DataSet> identification,
                   std::span<const DataSet> validation, const SemOptions& options);

// Automatic pick of the compact model: score = summed validation J (identification J when
// there is no validation data); among iterations whose score is within tolerance_percent of
// the lowest score, the one with fewest terms (then lowest score, then lowest iteration).
// Used with validation data, and without it when the spec's selection is "tolerance".
// Iterations that fail a check (FailsChecks: stress, monotone_in) are never picked (nor set the
// lowest score); -1 when every iteration failed one.
int SelectIteration(const std::vector<SemIteration>& iterations, double tolerance_percent);

// Contiguous time folds of every identification record used by the cross-validation.
inline constexpr int kSelectionFolds = 20;
// Fewest scored samples per fold and record for cross-validation; shorter records fall back
// to the tolerance rule on the identification J.
inline constexpr std::size_t kMinFoldSamples = 20;

// Cross-validated free-run cost of a structure inside the identification data: each record's
// scored samples (from spec.MaxDelay() on) are cut into `folds` contiguous parts; for fold f
// the coefficients are the one-step least squares on every other part of every record, and
// the model runs free over part f of each record (seeded with the measured output just before
// it). Returns per fold sum over records of (1/N_d) sum_k w_k (y - ysim)^2 (so the folds add up
// to a J-like total); +inf for a fold whose fit is singular or whose free run diverges.
std::vector<double> CrossValidatedCost(const SemSpec& spec, const std::vector<ChannelInfo>& ch,
                                       const std::vector<SemTerm>& terms,
                                       std::span<const DataSet> data, int folds);

// selection_noise = "auto": the cross-validation scores the one-step error when the lowest-J
// iteration's free-run residual is coloured and at least this share of its one-step residual's
// power is unpredictable from that residual's own past (an AR whitening fit, order <= 4 by
// BIC), and that share exceeds the free-run residual's; else the free run.
inline constexpr double kEquationNoiseShare = 0.5;

// Largest order of the AR whitening prefilter of the cross-validation selection (below).
inline constexpr int kMaxPrefilterOrder = 4;

// Pick by cross-validation with no tolerance to tune: cv[i] = fold costs of iterations[i]
// (CrossValidatedCost, or its output-error refined form when spec.refine; or, when the noise is
// taken to be in the equation (spec selection_noise, kEquationNoiseShare), the one-step form:
// least squares on the other folds, the weighted one-step squared error over the fold, N from
// the lowest-J iteration's one-step residual, no prefilter). In Identify the
// fold's weighted free-run residual z is first filtered by L(q) = 1 - a_1 q^-1 - ... - a_p q^-p,
// the least-squares AR fit of the lowest-J iteration's residual (p <= kMaxPrefilterOrder by
// BIC): output-error noise leaves that residual white (p = 0, L = 1, the plain free-run J);
// equation-error noise reaches it through the model's dynamics, coloured, and the plain J then
// weighs a few slow components heavily, so structures that the one-step error tells apart
// score alike (the prediction-error method with a fixed noise model; coefficients unchanged).
// samples = N, the
// effective number of independent samples (the selection takes n / (1 + 2 sum_l rho_l^2) from
// the free-run residual of the lowest-J iteration, rho_l its autocorrelations that exceed
// 2/sqrt(n)), candidates = C; the iteration of lowest
//   N ln(sum_f cv[i][f]) + m ln(N) + 2 ln(C choose m)      (m terms)
// an extended BIC (Chen & Chen 2008) on the cross-validated simulation error: the last part
// pays for having picked the m terms among C, which a greedy search over many candidates
// otherwise over-fits. Ties to the lower iteration. An iteration whose cross-validation
// diverges, or that fails a check (FailsChecks), is never picked (all diverging: the last that
// passed the stress check; -1 when none did). Identify then moves from the pick while the same
// score falls: it drops a term (drop_terms), or exchanges one for a candidate of the 8 best by
// one-step rank (score_exchange); each structure is scored on the same folds and prefilter,
// from its least squares, refined. The result is a further iteration, selected, and the rule
// lists the moves.
// The score above: N ln(cv) + m ln(N) + 2 ln(C choose m), cv the summed fold costs, m = terms,
// C = candidates (at least 1; m above C counts as C), N = samples (at least 2); +inf when cv is
// not finite and positive. Also scores off-path structures (Identify) and family members
// (sem_family.hpp).
double CrossValidationScore(double cv, std::size_t terms, double candidates, double samples);

int SelectByCrossValidation(const std::vector<SemIteration>& iterations,
                            const std::vector<std::vector<double>>& cv, double samples,
                            double candidates);

// Free-run cost of a model on one data set with the reference per-sample evaluation (no fast
// path): J of that data set alone, +inf when the simulation diverges. ysim (optional)
// receives the normalised simulated output for every row (measured values in the seed rows).
double SimulateCost(const SemSpec& spec, const std::vector<ChannelInfo>& channels,
                    const std::vector<SemTerm>& terms, const std::vector<double>& coefficients,
                    const DataSet& data, std::vector<double>* ysim = nullptr);

}  // namespace mrd::host
