// SearchPath::LocalSearch (search_path.hpp): local search under the selection's score
// (cross-validated selection only). The search prunes a term only when J falls without it, so a
// path can start with a spurious term (the one-step start) that it never drops; and it
// compares structures by the least squares' J, which output-error noise biases towards a close
// relative of a true term (y(k-2)^3 for y(k-2)^2). Either way the truth is then on no path.
// Moves from the pick: drop a term (drop_terms), or exchange one for a candidate of the
// kScorePool best by one-step rank (score_exchange). Each structure is fitted (least squares,
// refined) and scored on the selection's folds; the best move is taken while the score falls
// (a local minimum of the score). The result is a further iteration, selected, with the moves
// in the rule.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "sem/search/search_path.hpp"

namespace mrd::host::internal {

void SearchPath::LocalSearch(const SelectionCriterion& criterion) {
  if (!(spec_.drop_terms || spec_.score_exchange) || !criterion || res_.selected < 0) return;
  auto sel = std::find_if(res_.iterations.begin(), res_.iterations.end(),
                          [&](const SemIteration& it) { return it.iteration == res_.selected; });
  if (sel == res_.iterations.end() || sel->cv_j.empty()) return;
  SemIteration cur = *sel;
  std::vector<int> cur_model;
  for (const SemTerm& t : cur.terms) {
    const auto k = by_key_.find(TermKey(spec_, t));
    if (k == by_key_.end()) return;
    cur_model.push_back(k->second);
  }
  const auto name = [&](int c) { return TermName(spec_, eng_->cand(c).term); };
  double cur_score = criterion.Score(cur.cv_j, cur_model.size());
  std::vector<std::string> moves;
  for (int step = 0; step < kMaxScoreMoves; ++step) {
    const std::vector<Move> mv = ScoreMoves(cur_model, criterion);
    StressVerdict best_stress;
    const Move* best = BestMove(mv, cur_score, &best_stress);
    if (best == nullptr) break;
    moves.push_back(best->in < 0 ? fmt::format("dropped {}", name(cur_model[best->out]))
                                 : fmt::format("exchanged {} for {}", name(cur_model[best->out]),
                                               name(best->in)));
    cur_model = best->model;
    cur.terms = Terms(cur_model);
    cur.coefficients = best->theta;
    cur.j = best->j;
    cur.cv_j = best->cv;
    cur.stress = best_stress;
    cur.monotone = MonotoneOf(cur_model, cur.coefficients);
    cur_score = best->score;
  }
  if (moves.empty()) return;
  cur.iteration = res_.iterations.back().iteration + 1;
  cur.rejected = cur.stress_rejected = cur.monotone_rejected = 0;
  cur.elapsed_s = Elapsed();
  if (o_.progress) o_.progress(cur);
  res_.selected = cur.iteration;
  res_.iterations.push_back(std::move(cur));
  std::string list;
  for (const std::string& m : moves) {
    if (!list.empty()) list += ", ";
    list += m;
  }
  res_.selection_rule +=
      fmt::format("; then the pick changed while that lowers the score (iteration {}): {}",
                  res_.selected, list);
}

// Every drop and exchange of the pick, fitted by least squares (the engine's cache), then
// refined and scored on the folds in parallel.
std::vector<SearchPath::Move> SearchPath::ScoreMoves(const std::vector<int>& pick,
                                                     const SelectionCriterion& criterion) {
  std::vector<Move> mv;
  for (std::size_t i = 0; i < pick.size(); ++i) {
    std::vector<int> reduced = pick;
    reduced.erase(reduced.begin() + static_cast<std::ptrdiff_t>(i));
    std::vector<double> th;
    const bool solved = eng_->Solve(reduced, &th);
    if (spec_.drop_terms && !reduced.empty() && solved) {
      mv.push_back({reduced, th, {}, kInf, kInf, i, -1});
    }
    if (!spec_.score_exchange || !solved) continue;
    for (Trial& tr : search_->Ranked(reduced, th, kScorePool)) {  // theta: reduced, then c
      if (tr.cand == pick[i]) continue;
      Move x{reduced, std::move(tr.theta), {}, kInf, kInf, i, tr.cand};
      x.model.push_back(tr.cand);
      mv.push_back(std::move(x));
    }
  }
  ParallelFor(mv.size(), o_.threads, [&](std::size_t i, int) {
    Move& d = mv[i];
    d.cv = criterion.fold_costs(Terms(d.model), &d.theta, &d.j);
    d.score = criterion.Score(d.cv, d.model.size());
  });
  return mv;
}

// The move of the lowest score below `score` with a finite J that passes monotone_in and
// [stress] (first of equals); nullptr: none. *stress: its stress verdict (unchecked without
// [stress]).
const SearchPath::Move* SearchPath::BestMove(const std::vector<Move>& mv, double score,
                                             StressVerdict* stress) const {
  const Move* best = nullptr;
  for (const Move& d : mv) {
    if (!(d.score < (best != nullptr ? best->score : score)) || !std::isfinite(d.j)) {
      continue;
    }
    if (!MonotonePasses(d.model, d.theta)) continue;     // passes without monotone_in
    const StressVerdict v = StressOf(d.model, d.theta);  // unchecked without [stress]
    if (!stress_.empty() && !v.pass) continue;
    best = &d;
    *stress = v;
  }
  return best;
}

}  // namespace mrd::host::internal
