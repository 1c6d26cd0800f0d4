#include "sem/search/search.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>

namespace mrd::host::internal {
namespace {

// First improvement: candidates in rank order, in rounds of kRound (a constant: the early-stop
// bound is lowered between rounds, so the rounds must not depend on the thread count); a
// round is split evenly over the threads.
constexpr std::size_t kRound = 128;
constexpr std::size_t kChunk = 64;  // candidates per work item of the bordered least squares
// Best improvement: the kPilot best-ranked candidates run first (their lowest J is the early
// stop's bound from the start), then the rest in work items of kSweep candidates, each one
// sweep over the samples: a block's columns then serve kSweep jobs from the cache instead of
// being fetched again for every 64.
constexpr std::size_t kPilot = 16;
constexpr std::size_t kSweep = 256;
constexpr double kCollinear = 1e-13;  // relative Schur complement below which a
                                      // candidate is taken as linearly dependent

// Lowers an atomic double to v if v is smaller.
void AtomicMin(std::atomic<double>& a, double v) {
  double cur = a.load();
  while (v < cur && !a.compare_exchange_weak(cur, v)) {
  }
}

// Drops (cand = -1) the trials screen refuses, in parallel; counted as monotone refusals.
void ScreenTrials(const Search::Screen& screen, int threads, std::vector<Trial>* trials,
                  Search::Refusals* refusals) {
  std::vector<Trial>& t = *trials;
  std::atomic<int> n_screened{0};
  ParallelFor((t.size() + kChunk - 1) / kChunk, threads, [&](std::size_t item, int) {
    for (std::size_t c = item * kChunk; c < std::min(t.size(), (item + 1) * kChunk); ++c) {
      if (t[c].cand >= 0 && !screen(t[c].cand, t[c].theta)) {
        t[c].cand = -1;
        ++n_screened;
      }
    }
  });
  if (refusals != nullptr) refusals->monotone += n_screened.load();
}

// Free runs of the trials ord[begin, end) under the early-stop bound best: each trial's J (kInf
// when cut short or diverged), whether it was cut short; diverged runs counted in n_rejected.
void SimulateChunk(Engine& e, const std::vector<int>& model, const std::vector<int>& ord,
                   std::size_t begin, std::size_t end, std::atomic<double>& best,
                   std::vector<double>& scratch, std::vector<Trial>* trials,
                   std::atomic<int>& n_rejected) {
  // Jobs by the candidate's y power and input factor columns: lanes side by side then read
  // the same columns (cache lines shared). Each job's arithmetic is its own, so the order
  // changes no result.
  std::vector<std::size_t> idx(end - begin);
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = begin + i;
  std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
    const Cand& ca = e.cand((*trials)[ord[a]].cand);
    const Cand& cb = e.cand((*trials)[ord[b]].cand);
    return ca.ypow != cb.ypow ? ca.ypow < cb.ypow : ca.in_cols < cb.in_cols;
  });
  std::vector<Engine::Job> jobs(end - begin);
  for (std::size_t k = 0; k < idx.size(); ++k) {
    Trial& tr = (*trials)[ord[idx[k]]];
    jobs[k].theta.assign(tr.theta.begin(), tr.theta.end() - 1);
    jobs[k].extra = tr.cand;
    jobs[k].theta_extra = tr.theta.back();
  }
  e.Simulate(model, jobs, best, scratch);
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const std::size_t i = idx[k];
    const Engine::Job& job = jobs[k];
    Trial& tr = (*trials)[ord[i]];
    tr.j = job.dead ? kInf : job.cost;
    tr.cut = job.dead && !job.diverged;
    if (job.diverged) ++n_rejected;
  }
}

}  // namespace

double Search::Cost(const std::vector<int>& terms, std::vector<double>* theta) {
  if (!e_.Solve(terms, theta)) return kInf;
  if (terms.empty()) return e_.YtWy();
  return CostWith(terms, *theta, kInf);
}

double Search::CostWith(const std::vector<int>& terms, const std::vector<double>& theta,
                        double bnd) {
  Engine::Job job;
  job.theta = theta;
  std::atomic<double> bound{bnd};
  std::vector<double> scratch;
  e_.Simulate(terms, std::span<Engine::Job>(&job, 1), bound, scratch);
  return job.dead ? (job.diverged ? kInf : job.cost) : job.cost;
}

std::vector<Trial> Search::Bordered(const std::vector<int>& model, const std::vector<double>& w,
                                    std::atomic<int>& n_rejected) {
  const std::size_t m = model.size();
  // Cholesky of the model Gram matrix.
  Eigen::MatrixXd g(m, m);
  for (std::size_t i = 0; i < m; ++i) {
    const auto& ci = e_.Cross(model[i]);
    for (std::size_t j = 0; j < m; ++j) g(i, j) = ci[model[j]];
  }
  Eigen::LLT<Eigen::MatrixXd> llt(g);
  std::vector<const std::vector<double>*> cross(m);
  for (std::size_t i = 0; i < m; ++i) cross[i] = &e_.Cross(model[i]);
  // Bordered LS for every candidate, and its one-step SSE reduction for ranking.
  const std::size_t nc = e_.num_candidates();
  std::vector<Trial> trials(nc);
  std::vector<char> in_model(nc, 0);
  for (int t : model) in_model[t] = 1;
  ParallelFor((nc + kChunk - 1) / kChunk, threads_, [&](std::size_t item, int) {
    Eigen::VectorXd gc(m), z(m);
    Eigen::Map<const Eigen::VectorXd> wv(w.data(), static_cast<Eigen::Index>(m));
    for (std::size_t c = item * kChunk; c < std::min(nc, (item + 1) * kChunk); ++c) {
      Trial& tr = trials[c];
      if (in_model[c]) continue;
      const Cand& cd = e_.cand(static_cast<int>(c));
      for (std::size_t i = 0; i < m; ++i) gc(i) = (*cross[i])[c];
      double sigma = cd.ss, r = cd.sy;
      if (m > 0) {
        z = llt.solve(gc);
        sigma -= gc.dot(z);
        r -= gc.dot(wv);
      }
      if (!(sigma > kCollinear * cd.ss) || !std::isfinite(sigma)) {
        ++n_rejected;
        continue;
      }
      const double th = r / sigma;
      tr.cand = static_cast<int>(c);
      tr.rank = r * r / sigma;
      tr.theta.resize(m + 1);
      for (std::size_t i = 0; i < m; ++i) tr.theta[i] = w[i] - z(i) * th;
      tr.theta[m] = th;
    }
  });
  return trials;
}

std::vector<int> Search::RankOrder(const std::vector<Trial>& trials, std::size_t limit) {
  std::vector<int> order;
  for (std::size_t c = 0; c < trials.size(); ++c) {
    if (trials[c].cand >= 0) order.push_back(static_cast<int>(c));
  }
  // Largest SSE reduction first, ties by index.
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return trials[a].rank > trials[b].rank; });
  if (limit > 0 && order.size() > limit) order.resize(limit);
  return order;
}

std::vector<Trial> Search::Ranked(const std::vector<int>& model, const std::vector<double>& w,
                                  std::size_t limit) {
  std::atomic<int> n_rejected{0};
  std::vector<Trial> trials = Bordered(model, w, n_rejected);
  std::vector<Trial> out;
  for (int c : RankOrder(trials, limit)) out.push_back(std::move(trials[c]));
  return out;
}

Trial Search::TryAdd(const std::vector<int>& model, const std::vector<double>& w, bool first,
                     double j_threshold, int* rejected, const Accept& accept, Refusals* refusals,
                     std::size_t limit, double bound0, const Screen& screen) {
  std::atomic<int> n_rejected{0};
  struct Report {
    std::atomic<int>& n;
    int* out;
    ~Report() { *out = n.load(); }
  } report{n_rejected, rejected};
  std::vector<Trial> trials = Bordered(model, w, n_rejected);
  if (screen) ScreenTrials(screen, threads_, &trials, refusals);
  const std::vector<int> order = RankOrder(trials, limit);
  Trial none;
  if (order.empty()) return none;
  // The check's verdict per candidate, asked once (-1: not asked), counted when the choice
  // meets it.
  std::vector<signed char> verdict(trials.size(), -1);
  std::vector<char> counted(trials.size(), 0);
  auto ask = [&](int c) {
    verdict[c] = static_cast<signed char>(accept ? accept(c, trials[c].theta) : Verdict::kAccept);
  };
  bool refusals_met = false;
  auto accepted = [&](int c) {
    if (verdict[c] < 0) ask(c);
    const auto v = static_cast<Verdict>(verdict[c]);
    if (v != Verdict::kAccept && !counted[c]) {
      counted[c] = 1;
      refusals_met = true;
      if (refusals != nullptr) ++(v == Verdict::kMonotone ? refusals->monotone : refusals->stress);
    }
    return v == Verdict::kAccept;
  };
  // Admissible (finite J) candidates by J, ties by index, the first the check accepts. The
  // verdicts are asked one per thread ahead of the scan; the scan alone counts and chooses.
  auto best_accepted = [&](std::vector<int> ok) {
    std::sort(ok.begin(), ok.end(), [&](int a, int b) {
      return trials[a].j != trials[b].j ? trials[a].j < trials[b].j : a < b;
    });
    const auto batch = static_cast<std::size_t>(accept ? threads_ : 1);
    for (std::size_t i = 0; i < ok.size(); ++i) {
      if (verdict[ok[i]] < 0 && batch > 1) {
        std::vector<int> ahead;
        for (std::size_t k = i; k < ok.size() && ahead.size() < batch; ++k) {
          if (verdict[ok[k]] < 0) ahead.push_back(ok[k]);
        }
        ParallelFor(ahead.size(), threads_, [&](std::size_t item, int) { ask(ahead[item]); });
      }
      if (accepted(ok[i])) return trials[ok[i]];
    }
    return none;
  };
  // Bound for early stopping. First improvement never lowers it below the threshold, so no
  // candidate that would meet the threshold is cut short. The bound is lowered only between
  // parallel phases (after the serial pilot, after each round), never by a worker while others
  // run: which candidates are cut short, and so the fallback choice and the diverged count,
  // must not depend on thread timing.
  const double floor = first ? j_threshold : -kInf;
  std::atomic<double> best{bound0};
  for (int t : model) e_.U(t);  // materialise before the workers read them
  auto lower_bound_to = [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Trial& tr = trials[order[i]];
      if (tr.j < kInf) AtomicMin(best, std::max(tr.j, floor));
    }
  };
  auto run_chunk = [&](const std::vector<int>& ord, std::size_t begin, std::size_t end,
                       std::vector<double>& scratch) {
    SimulateChunk(e_, model, ord, begin, end, best, scratch, &trials, n_rejected);
  };
  if (!first) {
    std::vector<std::vector<double>> scratch(static_cast<std::size_t>(threads_));
    const std::size_t pilot = std::min(order.size(), kPilot);
    run_chunk(order, 0, pilot, scratch[0]);
    lower_bound_to(0, pilot);
    // The rest in sweeps of at most kSweep, split over the threads.
    auto sweep = [&](const std::vector<int>& ord, std::size_t from) {
      const std::size_t rest = ord.size() - from;
      const std::size_t per = std::max<std::size_t>(
          1, std::min(kSweep, (rest + static_cast<std::size_t>(threads_) - 1) /
                                  static_cast<std::size_t>(threads_)));
      const std::size_t chunks = (rest + per - 1) / per;
      ParallelFor(chunks, threads_, [&](std::size_t item, int worker) {
        run_chunk(ord, from + item * per, std::min(ord.size(), from + (item + 1) * per),
                  scratch[worker]);
      });
    };
    sweep(order, pilot);
    std::vector<int> ok;
    for (int c : order) {
      if (trials[c].j < kInf) ok.push_back(c);
    }
    const Trial pick = best_accepted(ok);
    if (!refusals_met) return pick;
    // The runs cut short again, under the pick's J (none: bound0), fixed: not lowered by a J the
    // check may refuse; the pick is then the accepted one of lowest J among all that completed.
    std::vector<int> again;
    for (int c : order) {
      if (trials[c].cut) again.push_back(c);
    }
    if (again.empty()) return pick;
    best.store(pick.cand >= 0 ? pick.j : bound0);
    sweep(again, 0);
    for (int c : again) {
      if (trials[c].j < kInf) ok.push_back(c);
    }
    return best_accepted(std::move(ok));
  }
  // First improvement: rank order, in rounds of kRound candidates.
  std::vector<std::vector<double>> scratch(static_cast<std::size_t>(threads_));
  std::vector<int> fallback;
  const auto workers = static_cast<std::size_t>(threads_);
  for (std::size_t r0 = 0; r0 < order.size(); r0 += kRound) {
    const std::size_t r1 = std::min(order.size(), r0 + kRound);
    const std::size_t per = (r1 - r0 + workers - 1) / workers;
    const std::size_t chunks = (r1 - r0 + per - 1) / per;
    ParallelFor(chunks, threads_, [&](std::size_t item, int worker) {
      run_chunk(order, r0 + item * per, std::min(r1, r0 + (item + 1) * per), scratch[worker]);
    });
    lower_bound_to(r0, r1);
    for (std::size_t i = r0; i < r1; ++i) {
      const int c = order[i];
      if (trials[c].j <= j_threshold && accepted(c)) return trials[c];
      if (trials[c].j < kInf && trials[c].j > j_threshold) fallback.push_back(c);
    }
  }
  return best_accepted(std::move(fallback));
}

}  // namespace mrd::host::internal
