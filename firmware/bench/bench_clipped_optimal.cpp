// Google Benchmark: the clipped-optimal law's period cost.
//   BM_ControllerUpdateClippedOptimal/clipped|inverse: through the Controller (below).
//   BM_ClippedOptimalUpdate: ClippedOptimal::Update (6-state observer update from 3 measured
//                            accelerations and the force, optimal force, clipped rule); dense
//                            gains, so the cost is that of the designed 3-story law.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/clipped_optimal.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/platform/clipped_optimal_file.hpp"

namespace {

using namespace mrd::firmware;            // NOLINT: benchmark file
using namespace mrd::firmware::platform;  // NOLINT

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

// BM_ControllerUpdateClippedOptimal/clipped|inverse: Controller::Update with law =
// "clipped-optimal" and the designed gains (hil/data/clipped_optimal_gains.toml, the file
// `mrd-structure design --out` writes): input checks of the three floor accelerations and
// the force, observer, clipped rule or the model's inverse at the desired force, model step.
// Structure-like inputs: 5.5 Hz first mode plus a 16 Hz component.
namespace {

void BM_ControllerUpdateClippedOptimal(benchmark::State& state, ClippedCommand command) {
  ControllerConfig config;
  config.law.mode = ControlMode::kClippedOptimal;
  config.law.clipped_command = command;
  std::string error;
  if (!LoadClippedOptimalGains(std::string(MRD_SOURCE_DIR) + "/hil/data/clipped_optimal_gains.toml",
                               &config.clipped_gains, &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  config.clipped_gains_loaded = true;
  Controller c;
  if (c.Configure(kBuiltinTable, config) != mrd::Error::kOk) {
    state.SkipWithError("table refused");
    return;
  }
  constexpr double kTwoPi = 6.283185307179586;
  SensorFrame frame;
  std::int64_t now = 0;
  int k = 0;
  for (auto _ : state) {
    now += 1'000'000;
    const double t = (k & 4095) * 1e-3;
    const double s1 = std::sin(kTwoPi * 5.5 * t), s2 = std::sin(kTwoPi * 16.0 * t);
    frame[Input::kVelocity] = {8.0 * std::cos(kTwoPi * 5.5 * t), now};       // [cm/s]
    frame[Input::kForce] = {300.0 * std::cos(kTwoPi * 5.5 * t + 0.3), now};  // [N]
    frame[FloorAcceleration(0)] = {2.0 * s1 + 0.5 * s2, now};                // [m/s^2]
    frame[FloorAcceleration(1)] = {3.0 * s1 - 0.3 * s2, now};
    frame[FloorAcceleration(2)] = {4.0 * s1 + 0.2 * s2, now};
    benchmark::DoNotOptimize(c.Update(frame, IoStatus::kOk, false, now, 1e-3));
    ++k;
  }
}
BENCHMARK_CAPTURE(BM_ControllerUpdateClippedOptimal, clipped, ClippedCommand::kClipped);
BENCHMARK_CAPTURE(BM_ControllerUpdateClippedOptimal, inverse, ClippedCommand::kInverse);

}  // namespace
