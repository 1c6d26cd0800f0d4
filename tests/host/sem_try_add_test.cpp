// Adding a term (Search::TryAdd, host/src/sem/search/search.cpp): the candidates run in parallel
// under an early-stop bound. Which candidates are cut short decides the next best when the stress
// check refuses the best, and the count of diverged candidates that goes into the model file;
// neither may depend on thread timing. Shown for 1 to 8 threads (more threads than cores, so
// the workers' order varies), repeated, against the single-thread result.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <utility>
#include <vector>

#include "sem/search/search.hpp"
#include "sem_engine_fixture.hpp"

namespace mrd::host::internal {
namespace {

using Fixture = PaperEngineFixture;

struct Outcome {
  Trial trial;
  int rejected = 0;
  Search::Refusals refused;
};

void ExpectSame(const Outcome& a, const Outcome& b, int threads, int repeat) {
  SCOPED_TRACE(testing::Message() << threads << " threads, repeat " << repeat);
  EXPECT_EQ(a.trial.cand, b.trial.cand);
  EXPECT_EQ(a.trial.j, b.trial.j);
  EXPECT_EQ(a.trial.theta, b.trial.theta);
  EXPECT_EQ(a.rejected, b.rejected);
  EXPECT_EQ(a.refused.stress, b.refused.stress);
  EXPECT_EQ(a.refused.monotone, b.refused.monotone);
}

TEST(SemTryAddTest, TheChoiceAndItsCountsDoNotDependOnTheThreadCount) {
  Fixture f;
  // A 4-term model by best improvement.
  std::vector<int> model;
  std::vector<double> theta;
  Search grow(f.eng, 1);
  for (int k = 0; k < 4; ++k) {
    int rej = 0;
    const Trial t = grow.TryAdd(model, theta, false, -kInf, &rej);
    ASSERT_GE(t.cand, 0);
    model.push_back(t.cand);
    theta = t.theta;
  }
  const double j_model = grow.Cost(model, &theta);
  // Every candidate's J run to the end (no bound); the stress check refuses the 40 best, so the
  // choice falls beyond the pilot, to candidates a tightened bound may have cut short.
  std::vector<std::pair<double, int>> by_j;
  for (const Trial& t : grow.Ranked(model, theta, 0)) {
    std::vector<int> m = model;
    m.push_back(t.cand);
    by_j.emplace_back(grow.CostWith(m, t.theta, kInf), t.cand);
  }
  std::sort(by_j.begin(), by_j.end());
  ASSERT_GT(by_j.size(), 600u);  // more than the pilot and two sweep items of 256
  std::set<int> refused;
  for (std::size_t k = 0; k < 40; ++k) refused.insert(by_j[k].second);
  // Refused by stress, or by monotone_in for odd candidates (counted apart).
  const Search::Accept accept = [&](int c, const std::vector<double>&) {
    if (refused.count(c) == 0) return Search::Verdict::kAccept;
    return c % 2 == 1 ? Search::Verdict::kMonotone : Search::Verdict::kStress;
  };
  // Best improvement, and first improvement with a target no candidate meets (its fallback).
  for (const bool first : {false, true}) {
    SCOPED_TRACE(first ? "first improvement" : "best improvement");
    auto run = [&](int threads) {
      Search s(f.eng, threads);
      Outcome o;
      o.trial = s.TryAdd(model, theta, first, first ? 1e-6 * j_model : -kInf, &o.rejected, accept,
                         &o.refused);
      return o;
    };
    const Outcome ref = run(1);
    ASSERT_GE(ref.trial.cand, 0);
    EXPECT_EQ(refused.count(ref.trial.cand), 0u);
    EXPECT_GE(ref.refused.stress + ref.refused.monotone, 1);  // the refusals were met
    for (int repeat = 0; repeat < 3; ++repeat) {
      for (const int threads : {2, 3, 8}) ExpectSame(ref, run(threads), threads, repeat);
    }
  }
}

}  // namespace
}  // namespace mrd::host::internal
