// Google Benchmark: the clipped-optimal law's period cost.
//   BM_ClippedOptimalUpdate: ClippedOptimal::Update (6-state observer update from 3 measured
//                            accelerations and the force, optimal force, clipped rule); dense
//                            gains, so the cost is that of the designed 3-story law.
#include <benchmark/benchmark.h>

#include "mrd/firmware/clipped_optimal.hpp"

namespace {

using namespace mrd::firmware;  // NOLINT: benchmark file

void BM_ClippedOptimalUpdate(benchmark::State& state) {
  ClippedOptimalGains g;
  constexpr int n = ClippedOptimalGains::kStates, m = ClippedOptimalGains::kOutputs;
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) g.ad[r * n + c] = (r == c) ? 0.9 : 0.01 * (r - c);
    for (int c = 0; c < m; ++c) g.l[r * m + c] = 1e-4 * (r + c + 1);
    g.bd[r] = 1e-6 * (r + 1);
    g.k[r] = -1e3 * (r + 1);
  }
  for (int i = 0; i < m * n; ++i) g.cy[i] = -1e3 + 10.0 * i;
  for (double& d : g.dy) d = -0.01;
  ClippedOptimal law;
  law.Configure(g);
  int k = 0;
  for (auto _ : state) {
    const Real accel[3] = {Real(0.1 * (k % 7)), Real(-0.05 * (k % 3)), Real(0.2)};
    benchmark::DoNotOptimize(law.Update(accel, Real((k % 11) - 5)));
    ++k;
  }
}
BENCHMARK(BM_ClippedOptimalUpdate);

}  // namespace
