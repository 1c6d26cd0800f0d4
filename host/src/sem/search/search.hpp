#pragma once
// The SEM search's candidate trials (used by host/src/sem/identify.cpp's Identify): least squares
// of every candidate added to a model (bordered on the model's Cholesky factor), its one-step rank,
// and the free runs that pick one by J, first or best improvement. Not public.

#include <atomic>
#include <cstddef>
#include <functional>
#include <vector>

#include "sem/engine/engine.hpp"

namespace mrd::host::internal {

// Outcome of trying one candidate.
struct Trial {
  int cand = -1;
  double j = kInf;
  double rank = 0.0;          // one-step SSE reduction
  bool cut = false;           // its free run stopped at the early-stop bound (j = kInf)
  std::vector<double> theta;  // model terms then the candidate
};

class Search {
 public:
  Search(Engine& e, int threads) : e_(e), threads_(std::max(1, threads)) {}

  // Full-model free-run cost (no bound), +inf when diverging or singular.
  double Cost(const std::vector<int>& terms, std::vector<double>* theta);

  // Free-run cost of terms with coefficients theta; a run whose partial cost exceeds bnd
  // stops (then its partial cost, a lower bound, is returned); +inf when diverging.
  double CostWith(const std::vector<int>& terms, const std::vector<double>& theta, double bnd);

  // Tries adding every eligible candidate. Returns the chosen trial (cand < 0: none
  // admissible). first: first-improvement with target j_threshold.
  // accept (optional): the checks of model + candidate with the trial's coefficients (stress,
  // monotone_in); a candidate it refuses is skipped (counted in *refusals by its verdict) for
  // the next best. accept must only read: TryAdd asks it for several candidates at once, one
  // per thread, but counts and chooses in J order, so the result and the counts are those of
  // asking one candidate at a time. Best improvement then returns the admissible candidate of
  // lowest J that the check accepts: a refused candidate's J may have cut other runs short, so
  // after a refusal the runs cut short run again, bounded by the J of the accepted pick (none:
  // unbounded).
  // limit > 0: simulate only the `limit` candidates of best one-step rank. bound0: only
  // candidates whose J is below it are admissible (early stop from the start).
  // Best single-term drop (host/src/sem/identify.cpp's pruning, host/src/sem/search/prune.cpp): the
  // index in model of the term whose removal gives the lowest free-run J (least squares of the
  // reduced model), that J and the reduced model's coefficients (theta). Only reduced models with J
  // <= bound count; none: returns kInf (drop and theta unchanged). Ties: the lowest index. The
  // reduced models run in parallel under a shared early-stop bound (the lowest J completed so far):
  // exact, since a partial cost only grows, so the run stopped never has the lowest J; the result
  // is the same for every thread count.
  double BestDrop(const std::vector<int>& model, double bound, std::size_t* drop,
                  std::vector<double>* theta);

  enum class Verdict { kAccept, kMonotone, kStress };
  // Candidates refused, by the check that refused them.
  struct Refusals {
    int monotone = 0;  // by monotone_in (accept's kMonotone, or the screen)
    int stress = 0;    // by the stress check (accept's kStress)
  };
  using Accept = std::function<Verdict(int cand, const std::vector<double>& theta)>;
  using Screen = std::function<bool(int cand, const std::vector<double>& theta)>;
  // screen (optional): a check of model + candidate that needs no free run (the monotone_in
  // grid); a candidate it refuses never runs and counts in refusals->monotone. Every candidate
  // it refuses is one accept would refuse too, so it changes no pick, only the time.
  Trial TryAdd(const std::vector<int>& model, const std::vector<double>& w, bool first,
               double j_threshold, int* rejected, const Accept& accept = {},
               Refusals* refusals = nullptr, std::size_t limit = 0, double bound0 = kInf,
               const Screen& screen = {});

  // The candidates (not in model) by one-step rank given the model's least squares w, best
  // first, at most limit (0: all), with the least squares of model + candidate; no free run
  // and no Gram column of the candidates (Engine::Cross), j unset.
  std::vector<Trial> Ranked(const std::vector<int>& model, const std::vector<double>& w,
                            std::size_t limit);

 private:
  // Bordered least squares of every candidate added to model (cand < 0: in the model or
  // collinear, the latter counted in n_rejected).
  std::vector<Trial> Bordered(const std::vector<int>& model, const std::vector<double>& w,
                              std::atomic<int>& n_rejected);
  static std::vector<int> RankOrder(const std::vector<Trial>& trials, std::size_t limit);

  Engine& e_;
  int threads_;
};

}  // namespace mrd::host::internal
