// Google Benchmark: what runtime parameters cost the loop.
//   BM_ParamsHookIdle:   RuntimeParams::BeforePeriod with nothing pending (every period's cost)
//   BM_ControllerRetune: Controller::Retune (the period a `ctl set` is applied)
#include <benchmark/benchmark.h>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/platform/runtime_params.hpp"

namespace {

using namespace mrd::firmware;            // NOLINT: benchmark file
using namespace mrd::firmware::platform;  // NOLINT

void BM_ParamsHookIdle(benchmark::State& state) {
  FirmwareConfig config;
  config.controller.e_max = kBuiltinTable.e_max;
  Controller c;
  if (c.Configure(kBuiltinTable, config.controller) != mrd::Error::kOk) {
    state.SkipWithError("table refused");
    return;
  }
  RuntimeParams params(kBuiltinTable, config);
  std::uint64_t period = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(params.BeforePeriod(c, period++, 0));
    benchmark::DoNotOptimize(params.version());
  }
}
BENCHMARK(BM_ParamsHookIdle);

void BM_ControllerRetune(benchmark::State& state) {
  ControllerConfig a, b;
  a.e_max = b.e_max = kBuiltinTable.e_max;
  a.law.mode = b.law.mode = ControlMode::kSkyhookContinuous;
  b.law.skyhook_gain = 60.0;
  b.envelope_margin = 0.2;
  Controller c;
  if (c.Configure(kBuiltinTable, a) != mrd::Error::kOk) {
    state.SkipWithError("table refused");
    return;
  }
  bool flip = false;
  for (auto _ : state) {
    benchmark::DoNotOptimize(c.Retune(flip ? a : b));
    flip = !flip;
  }
}
BENCHMARK(BM_ControllerRetune);

}  // namespace
