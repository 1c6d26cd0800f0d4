// Google Benchmark: the per-period log's cost to the loop (period_log.hpp).
//   BM_PeriodLogPush: PeriodLog::OnPeriod, the observer's copy of one record into the ring
//                     with the writer thread running (file /dev/null). The timer pauses every
//                     half ring to let the writer drain, so every timed push is a real push
//                     (counter "dropped" must be 0), never the cheaper drop path.
#include <benchmark/benchmark.h>

#include <chrono>
#include <thread>

#include "mrd/firmware/platform/period_log.hpp"

namespace {

using namespace mrd::firmware;            // NOLINT: benchmark file
using namespace mrd::firmware::platform;  // NOLINT

void BM_PeriodLogPush(benchmark::State& state) {
  LogConfig config;
  config.path = "/dev/null";
  config.ring_records = 8192;
  PeriodLog log;
  log.Start(config, 1'000'000, "bench");
  PeriodRecord r;
  r.frame[Input::kVelocity] = {12.0, 0};
  std::uint64_t k = 0;
  for (auto _ : state) {
    r.period = k;
    r.t_ns = static_cast<std::int64_t>(k) * 1'000'000;
    log.OnPeriod(r);
    if ((++k & 4095) == 0) {
      state.PauseTiming();
      while (log.backlog() > 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
      state.ResumeTiming();
    }
  }
  log.Stop();
  state.counters["dropped"] = static_cast<double>(log.stats().dropped);
  state.counters["record_bytes"] = static_cast<double>(sizeof(PeriodRecord));
}
BENCHMARK(BM_PeriodLogPush);

}  // namespace
