// Pruning step of the SEM search (Search::BestDrop, host/src/sem/search/prune.cpp): the parallel
// runs of the reduced models under a shared early-stop bound pick the same term, J and coefficients
// as running every reduced model to the end, for 1 and 2 threads and any bound.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sem/search/search.hpp"
#include "sem_engine_fixture.hpp"

namespace mrd::host::internal {
namespace {

using Fixture = PaperEngineFixture;

// Reference: every reduced model solved and run to the end (no bound); the lowest J at or
// below bound, lowest index on ties.
double BruteForce(Engine& eng, Search& s, const std::vector<int>& model, double bound,
                  std::size_t* drop, std::vector<double>* theta) {
  double best = kInf;
  for (std::size_t i = 0; i < model.size(); ++i) {
    std::vector<int> r = model;
    r.erase(r.begin() + static_cast<std::ptrdiff_t>(i));
    std::vector<double> th;
    if (!eng.Solve(r, &th)) continue;
    const double j = s.CostWith(r, th, kInf);
    if (j <= bound && j < best) {
      best = j;
      *drop = i;
      *theta = th;
    }
  }
  return best;
}

TEST(SemPruneTest, BestDropMatchesRunningEveryReducedModelToTheEnd) {
  Fixture f;
  Search grow(f.eng, 2);
  // A model of 7 terms by best improvement (its J, and the reduced models' Js, are distinct).
  std::vector<int> model;
  std::vector<double> theta;
  for (int k = 0; k < 7; ++k) {
    int rej = 0;
    const Trial t = grow.TryAdd(model, theta, false, -kInf, &rej, {}, nullptr);
    ASSERT_GE(t.cand, 0);
    model.push_back(t.cand);
    theta = t.theta;
  }
  const double j_full = grow.Cost(model, &theta);
  ASSERT_TRUE(std::isfinite(j_full));
  Search ref_search(f.eng, 1);
  std::size_t ref_drop = 99;
  std::vector<double> ref_theta;
  const double ref = BruteForce(f.eng, ref_search, model, kInf, &ref_drop, &ref_theta);
  ASSERT_TRUE(std::isfinite(ref));
  ASSERT_LT(ref_drop, model.size());
  // Bounds: none, just above the best reduced J (all others stop early), exactly the best
  // (it still counts: J <= bound), the full model's J.
  for (const double bound : {kInf, ref * 1.0001, ref, j_full}) {
    for (const int threads : {1, 2}) {
      Search s(f.eng, threads);
      std::size_t drop = 99;
      std::vector<double> th;
      const double j = s.BestDrop(model, bound, &drop, &th);
      std::size_t want_drop = 99;
      std::vector<double> want_theta;
      const double want = BruteForce(f.eng, ref_search, model, bound, &want_drop, &want_theta);
      EXPECT_EQ(j, want) << "bound " << bound << ", threads " << threads;
      if (std::isfinite(want)) {
        EXPECT_EQ(drop, want_drop) << "bound " << bound << ", threads " << threads;
        EXPECT_EQ(th, want_theta) << "bound " << bound << ", threads " << threads;
      }
    }
  }
}

TEST(SemPruneTest, BestDropBelowEveryReducedJReturnsInfinityAndLeavesOutputs) {
  Fixture f;
  Search s(f.eng, 2);
  std::vector<int> model;
  std::vector<double> theta;
  for (int k = 0; k < 4; ++k) {
    int rej = 0;
    const Trial t = s.TryAdd(model, theta, false, -kInf, &rej, {}, nullptr);
    ASSERT_GE(t.cand, 0);
    model.push_back(t.cand);
    theta = t.theta;
  }
  std::size_t drop = 77;
  std::vector<double> th{1.0, 2.0};
  // Bound 0: every reduced model has J > 0 (noisy data), so every run stops early.
  EXPECT_EQ(s.BestDrop(model, 0.0, &drop, &th), kInf);
  EXPECT_EQ(drop, 77u);
  EXPECT_EQ(th, (std::vector<double>{1.0, 2.0}));
}

}  // namespace
}  // namespace mrd::host::internal
