// Benchmark of the full paper run (docs/design.md §5): reference identification set (seed 1,
// 40k samples), host/specs/paper.toml (1551 candidates), 20 major iterations, best
// improvement, 1 or 2 threads, with and without the output-error refinement. Reports J and
// terms of the final model as counters.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <string>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/sem.hpp"
#include "sem/engine/kernels.hpp"
#include "sem/estimate/evaluator.hpp"
#include "sem/internal.hpp"
#include "sem_test_util.hpp"

namespace {

// range(0): threads; range(1): 1 = paper.toml as it is (output-error refinement of every
// iteration), 0 = refine = false (the search alone).
void BM_SemPaperRun(benchmark::State& state) {
  mrd::host::SemSpec spec =
      mrd::host::LoadSemSpec(std::string(MRD_SOURCE_DIR) + "/host/specs/paper.toml");
  spec.refine = state.range(1) != 0;
  const std::vector<mrd::host::DataSet> id{mrd::test::DamperData("identification")};
  mrd::host::SemOptions o;
  o.max_iterations = 20;
  o.threads = static_cast<int>(state.range(0));
  mrd::host::SemResult r;
  for (auto _ : state) {
    r = mrd::host::Identify(spec, id, {}, o);
    benchmark::DoNotOptimize(r);
  }
  state.counters["candidates"] = static_cast<double>(r.num_candidates);
  state.counters["J"] = r.iterations.back().j;
  state.counters["terms"] = static_cast<double>(r.iterations.back().terms.size());
  double j6 = 1e9, j13 = 1e9;  // best J among models of at most 6 / 13 terms
  for (const auto& it : r.iterations) {
    if (it.terms.size() <= 6) j6 = std::min(j6, it.j);
    if (it.terms.size() <= 13) j13 = std::min(j13, it.j);
  }
  state.counters["J_le6"] = j6;
  state.counters["J_le13"] = j13;
}
BENCHMARK(BM_SemPaperRun)
    ->ArgNames({"threads", "refine"})
    ->Args({2, 1})
    ->Args({1, 1})
    ->Args({2, 0})
    ->Args({1, 0})
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

// The paper run as shipped (2 threads, refinement) with the kernels at 4 doubles per vector:
// what a CPU without AVX-512F runs (on one that has it, BM_SemPaperRun runs 8 per vector).
void BM_SemPaperRunFourWide(benchmark::State& state) {
  mrd::host::internal::SetLaneWidth(4);
  BM_SemPaperRun(state);
  mrd::host::internal::SetLaneWidth(0);
}
BENCHMARK(BM_SemPaperRunFourWide)
    ->ArgNames({"threads", "refine"})
    ->Args({2, 1})
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

// The output-error refinement alone (Levenberg-Marquardt on the free-run J): the paper run's
// final 14-term structure, from its least-squares coefficients (the search without refinement).
void BM_SemRefine(benchmark::State& state) {
  mrd::host::SemSpec spec =
      mrd::host::LoadSemSpec(std::string(MRD_SOURCE_DIR) + "/host/specs/paper.toml");
  spec.refine = false;
  const std::vector<mrd::host::DataSet> id{mrd::test::DamperData("identification")};
  mrd::host::SemOptions o;
  o.max_iterations = 20;
  o.threads = 2;
  const mrd::host::SemResult r = mrd::host::Identify(spec, id, {}, o);
  const std::vector<mrd::host::internal::Evaluator> ev{{spec, r.channels, id[0]}};
  const auto& last = r.iterations.back();
  double j = 0.0;
  for (auto _ : state) {
    std::vector<double> theta = last.coefficients;
    j = mrd::host::internal::RefineFreeRun(ev, last.terms, &theta);
    benchmark::DoNotOptimize(theta);
  }
  state.counters["terms"] = static_cast<double>(last.terms.size());
  state.counters["J_start"] = last.j;
  state.counters["J"] = j;
}
BENCHMARK(BM_SemRefine)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
