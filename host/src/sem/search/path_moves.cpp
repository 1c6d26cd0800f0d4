// SearchPath (search_path.hpp): recording an iteration and the moves of one path (add, prune,
// exchange).
#include <cstddef>
#include <utility>

#include "sem/search/search_path.hpp"

namespace mrd::host::internal {

// The stress check, validation and refinement of a recorded iteration do not feed the search:
// with two or more threads they run beside the search of the next iteration (one iteration at
// a time, so the iterations are completed, reported and stored in order). The results are the
// same either way.
void SearchPath::Record(int iteration, int rejected, int stress_rejected, int monotone_rejected) {
  SemIteration it;
  it.iteration = iteration;
  it.rejected = rejected;
  it.stress_rejected = stress_rejected;
  it.monotone_rejected = monotone_rejected;
  it.terms = Terms(model_);
  it.coefficients = theta_;
  it.j = j_;
  FinishRecorded();
  if (o_.threads > 1) {
    refining_ = std::async(
        std::launch::async,
        [this, it = std::move(it), terms = model_]() mutable { Complete(std::move(it), terms); });
  } else {
    Complete(std::move(it), model_);
  }
}

void SearchPath::Complete(SemIteration it, const std::vector<int>& terms) {
  it.stress = StressOf(terms, it.coefficients);
  it.monotone = MonotoneOf(terms, it.coefficients);
  it.validation_j = Validate(it.terms, it.coefficients);
  if (spec_.refine && !terms.empty()) Refine(it, terms);
  it.elapsed_s = Elapsed();
  if (o_.progress) o_.progress(it);
  res_.iterations.push_back(std::move(it));
}

// Output-error refinement, kept when it lowers J, passes the stress check and monotone_in as
// the least squares did, and, with validation data, makes no validation set's J worse.
void SearchPath::Refine(SemIteration& it, const std::vector<int>& terms) const {
  std::vector<double> refined = it.coefficients;
  const double jr = RefineFreeRun(evaluators_, it.terms, &refined, nullptr, nullptr, &refine_ws_);
  const bool lower = jr < it.j;
  const StressVerdict sv = lower ? StressOf(terms, refined) : StressVerdict{};
  const MonotoneVerdict mv = lower ? MonotoneOf(terms, refined) : MonotoneVerdict{};
  const std::vector<double> vj = lower ? Validate(it.terms, refined) : std::vector<double>{};
  bool no_worse = true;  // on every validation set
  for (std::size_t i = 0; i < vj.size(); ++i) no_worse &= vj[i] <= it.validation_j[i];
  if (lower && (sv.pass || !it.stress.pass) && (mv.pass || !it.monotone.pass) && no_worse) {
    it.coefficients = std::move(refined);
    it.j = jr;
    it.stress = sv;
    it.monotone = mv;
    it.validation_j = vj;
  }
}

void SearchPath::FinishRecorded() {
  if (refining_.valid()) refining_.get();
}

// One iteration: add (first or best improvement), prune, exchange while that lowers J (each
// exchange pruned again), record.
bool SearchPath::Add(int iteration) {
  const double j_prev = j_;
  int rejected = 0;
  Search::Refusals refused;
  const Trial tr = search_->TryAdd(model_, theta_, strategy_ == Strategy::kFirst,
                                   j_prev * (1.0 - threshold_ / 100.0), &rejected,
                                   AcceptFor(model_), &refused, 0, kInf, ScreenFor(model_));
  if (tr.cand < 0) {  // nothing admissible
    res_.exhausted_rejected = rejected;
    return false;
  }
  model_.push_back(tr.cand);
  j_ = search_->Cost(model_, &theta_);
  Prune(j_prev);
  const int exchanges = spec_.exchange ? kMaxExchanges : 0;
  const auto tx = std::chrono::steady_clock::now();
  for (int pass = 0; pass < exchanges && Exchange(&rejected, &refused); ++pass) {
    Prune(j_prev);
  }
  if (exchanges > 0) {
    res_.exchange_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - tx).count();
  }
  Record(iteration, rejected, refused.stress, refused.monotone);
  return true;
}

// Drops the term whose removal gives the lowest J while that J is below j_prev (and, with
// [stress] or monotone_in, the reduced model passes those checks).
void SearchPath::Prune(double j_prev) {
  while (model_.size() > 1) {
    std::size_t drop = 0;
    std::vector<double> best_theta;
    const double best = search_->BestDrop(model_, j_prev, &drop, &best_theta);
    if (!(best < j_prev)) break;
    if (!stress_.empty() || gate_) {  // a pruned model must pass the checks too
      std::vector<int> reduced = model_;
      reduced.erase(reduced.begin() + static_cast<std::ptrdiff_t>(drop));
      if (!MonotonePasses(reduced, best_theta)) break;
      if (!stress_.empty() && !SearchStressPasses(reduced, best_theta)) break;
    }
    model_.erase(model_.begin() + static_cast<std::ptrdiff_t>(drop));
    theta_ = best_theta;
    j_ = best;
  }
}

// Best single exchange: for every term, the candidate that best replaces it (among the
// kExchangePool best by one-step rank); applied when it lowers J. False when none does.
bool SearchPath::Exchange(int* rejected, Search::Refusals* refused) {
  double best_j = j_ * (1.0 - kExchangeGain);
  Trial best;
  std::vector<int> best_model;
  for (std::size_t i = 0; i < model_.size(); ++i) {
    std::vector<int> reduced = model_;
    reduced.erase(reduced.begin() + static_cast<std::ptrdiff_t>(i));
    std::vector<double> th;
    if (!eng_->Solve(reduced, &th)) continue;
    int rej = 0;
    const Trial tr = search_->TryAdd(reduced, th, false, -kInf, &rej, AcceptFor(reduced), refused,
                                     kExchangePool, best_j, ScreenFor(reduced));
    *rejected += rej;
    if (tr.cand >= 0 && tr.cand != model_[i] && tr.j < best_j) {
      best_j = tr.j;
      best = tr;
      best_model = std::move(reduced);
    }
  }
  if (best.cand < 0) return false;
  model_ = std::move(best_model);
  model_.push_back(best.cand);
  theta_ = best.theta;
  j_ = best.j;
  return true;
}

// One search path from the current model: iteration 0 is the start, then Add until target_j,
// max_iterations, the samples per parameter or no admissible term.
void SearchPath::RunPath() {
  j_ = search_->Cost(model_, &theta_);
  Record(0, 0, 0, 0);
  for (int iteration = 1; iteration <= max_it_; ++iteration) {
    if (j_ <= target_) break;
    if (model_.size() + 1 > max_params_) break;  // kMinSamplesPerParameter
    if (!Add(iteration)) break;
  }
  FinishRecorded();
}

}  // namespace mrd::host::internal
