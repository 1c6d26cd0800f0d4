// Pruning step of the SEM search (host/src/sem/search/search.hpp, Search::BestDrop): the reduced
// models (one term dropped each) solved by least squares, then run in parallel under a shared
// bound.
#include <atomic>
#include <span>

#include "sem/search/search.hpp"

namespace mrd::host::internal {

double Search::BestDrop(const std::vector<int>& model, double bound, std::size_t* drop,
                        std::vector<double>* theta) {
  const std::size_t m = model.size();
  std::vector<std::vector<int>> reduced(m, model);
  std::vector<std::vector<double>> th(m);
  std::vector<char> solved(m, 0);
  // Serial: Solve and U fill the engine's caches, which the parallel runs only read.
  for (std::size_t i = 0; i < m; ++i) {
    reduced[i].erase(reduced[i].begin() + static_cast<std::ptrdiff_t>(i));
    solved[i] = e_.Solve(reduced[i], &th[i]) ? 1 : 0;
  }
  for (int t : model) e_.U(t);
  // Shared bound: the lowest J completed so far (bound at first). A run stops once its partial
  // cost (non-decreasing: a sum of non-negative terms) exceeds it, so its J exceeds a J already
  // reached (or the bound) and cannot be the lowest; the lowest always completes.
  std::atomic<double> best{bound};
  std::vector<double> cost(m, kInf);
  ParallelFor(m, threads_, [&](std::size_t i, int) {
    if (!solved[i]) return;
    Engine::Job job;
    job.theta = th[i];
    std::vector<double> scratch;
    e_.Simulate(reduced[i], std::span<Engine::Job>(&job, 1), best, scratch);
    if (job.dead) return;  // diverged, or above a J reached
    cost[i] = job.cost;
    double cur = best.load();
    while (job.cost < cur && !best.compare_exchange_weak(cur, job.cost)) {
    }
  });
  double j = kInf;
  for (std::size_t i = 0; i < m; ++i) {
    if (cost[i] < j) {  // strict: ties keep the lowest index
      j = cost[i];
      *drop = i;
    }
  }
  if (j < kInf) *theta = std::move(th[*drop]);
  return j;
}

}  // namespace mrd::host::internal
