#pragma once
// One identification run (Identify, sem.hpp) as a search path: the state the moves share (the
// engine and its candidates, the current model with its least squares and J, the recorded
// iterations) and the moves as methods. Not public.
//
//   SearchPath path(spec, identification, validation, options);  // checks, candidates
//   SemResult res = path.Run();  // path, second start, selection, local search under the score
//
// Moves: Add (one iteration: add a term, Prune, Exchange), RunPath (iterations until target_j,
// max_iterations or no admissible term), SecondStart (a second path from the one-step
// forward-regression start, the better path kept), Select, LocalSearch (the pick moved while
// the cross-validated score falls). Files: search_path.cpp (set-up, Run, second start),
// path_moves.cpp (record, add, prune, exchange), score_search.cpp (local search).

#include <chrono>
#include <cstddef>
#include <future>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mrd/host/sem.hpp"
#include "mrd/host/sem_stress.hpp"
#include "sem/engine/engine.hpp"
#include "sem/estimate/evaluator.hpp"
#include "sem/estimate/replay.hpp"
#include "sem/internal.hpp"
#include "sem/search/monotone_gate.hpp"
#include "sem/search/search.hpp"

namespace mrd::host::internal {

class SearchPath {
 public:
  // Checks the data and the settings (InputError), builds the candidates and the initial model
  // (spec.initial or options.initial) with its least squares and J.
  SearchPath(const SemSpec& spec, std::span<const DataSet> identification,
             std::span<const DataSet> validation, const SemOptions& o);
  SearchPath(const SearchPath&) = delete;
  SearchPath& operator=(const SearchPath&) = delete;

  // The whole identification; call once. InputError when no iteration passes [stress].
  SemResult Run();

 private:
  static constexpr int kMaxExchanges = 8;           // exchange passes per major iteration
  static constexpr std::size_t kExchangePool = 64;  // candidates (best one-step rank) per term
  static constexpr double kExchangeGain = 1e-9;     // relative J decrease an exchange must bring
  static constexpr std::size_t kScorePool = 8;      // candidates per term, exchanges (score)
  static constexpr int kMaxScoreMoves = 16;         // moves of the pick under the score

  // A structure one move from the pick (LocalSearch).
  struct Move {
    std::vector<int> model;
    std::vector<double> theta;
    std::vector<double> cv;
    double j = kInf;
    double score = kInf;
    std::size_t out = 0;  // index of the dropped or exchanged term in the pick
    int in = -1;          // the candidate exchanged in (-1: a drop)
  };

  // Set-up (search_path.cpp), in the order of the checks.
  void CheckSettings();
  void CheckSamples();
  void WarnConstantSignals() const;
  void BuildCandidates();
  void PrepareRuns();

  // Shared helpers.
  double Elapsed() const;  // [s] since the start
  std::vector<SemTerm> Terms(const std::vector<int>& model) const;
  // The stress check of a recorded iteration or a move of the pick: stretched, swept and rest
  // records; SearchStressOf: the search's, without the rest records (sem_stress.hpp);
  // SearchStressPasses: its verdict alone, each run stopped at its first sample out of bound.
  StressVerdict StressOf(const std::vector<int>& terms, const std::vector<double>& th) const;
  StressVerdict SearchStressOf(const std::vector<int>& terms, const std::vector<double>& th) const;
  bool SearchStressPasses(const std::vector<int>& terms, const std::vector<double>& th) const;
  // The invertibility check (spec monotone_in) of a model; unchecked without it.
  MonotoneVerdict MonotoneOf(const std::vector<int>& terms, const std::vector<double>& th) const;
  bool MonotonePasses(const std::vector<int>& terms, const std::vector<double>& th) const;
  // The checks of base + candidate: monotone_in, then the stress check (SearchStressPasses);
  // none without either. Thread-safe (reads only).
  Search::Accept AcceptFor(const std::vector<int>& base) const;
  // The monotone_in check of base + candidate on the grid's corners alone (none without
  // monotone_in): TryAdd's screen. Thread-safe.
  Search::Screen ScreenFor(const std::vector<int>& base) const;
  std::vector<double> Validate(const std::vector<SemTerm>& terms,
                               const std::vector<double>& coefficients) const;

  // Recording (path_moves.cpp): stress check, validation and refinement of an iteration,
  // beside the next search step with two or more threads.
  void Record(int iteration, int rejected, int stress_rejected, int monotone_rejected);
  void Complete(SemIteration it, const std::vector<int>& terms);
  void Refine(SemIteration& it, const std::vector<int>& terms) const;
  void FinishRecorded();

  // Path moves (path_moves.cpp).
  bool Add(int iteration);  // false: no admissible term
  void Prune(double j_prev);
  bool Exchange(int* rejected, Search::Refusals* refused);
  void RunPath();

  // Second start and selection (search_path.cpp).
  std::size_t OneStepStart();
  void SecondStart(SelectionCriterion* criterion);

  // Local search under the selection's score (score_search.cpp).
  void LocalSearch(const SelectionCriterion& criterion);
  std::vector<Move> ScoreMoves(const std::vector<int>& pick, const SelectionCriterion& criterion);
  const Move* BestMove(const std::vector<Move>& mv, double score, StressVerdict* stress) const;

  const SemSpec& spec_;
  std::span<const DataSet> identification_;
  std::span<const DataSet> validation_;
  const SemOptions& o_;
  const std::chrono::steady_clock::time_point t0_;
  const Strategy strategy_;
  const double threshold_;
  const int max_it_;
  const double target_;
  const std::vector<std::string>& initial_;

  SemResult res_;
  std::vector<DataSet> stress_, rest_;
  std::optional<MonotoneGate> gate_;  // spec monotone_in
  std::size_t samples_ = 0;           // scored samples of the identification data
  std::size_t max_params_ = 0;        // samples_ / kMinSamplesPerParameter
  std::optional<Engine> eng_;
  std::map<std::string, int> by_key_;  // TermKey -> candidate
  std::optional<Search> search_;
  // Stress and validation records prepared once for their many reference runs.
  std::vector<Replay> stress_runs_, rest_runs_, validation_runs_;
  std::vector<Evaluator> evaluators_;  // for the output-error refinement
  // Its buffers, kept across the iterations (one refinement runs at a time: Record joins the
  // previous one before it starts the next).
  mutable RefineWorkspace refine_ws_;

  std::vector<int> model_;  // current structure (candidate indices)
  std::vector<double> theta_;
  double j_ = kInf;
  std::future<void> refining_;  // the recorded iteration being completed (last: joined first)
};

}  // namespace mrd::host::internal
