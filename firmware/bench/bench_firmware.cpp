// Google Benchmark: one control period's computation on the compiled-in table, in the
// firmware's scalar type Real (double; float with MRD_REAL=float: the context line "mrd_real").
//   BM_ModelStepAndInversion: Begin + Inverter::Solve + Finish (the model/inversion core)
//   BM_ModelStep:             Begin + Finish (forward model only)
//   BM_ControllerUpdate:      watchdog + law + inversion + model (Controller::Update)
//   BM_Profile*Period/NAME:   one period's wire work of each device profile (bench_profiles.cpp)
// MRD_BENCH_TABLE=FILE adds BM_ModelStepAndInversion/file on that exported table (e.g. the
// NEES model with its low-pass command regressor).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/inverter.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "mrd/firmware/platform/table_file.hpp"
#include "mrd/sim/quarter_car.hpp"

namespace {

using namespace mrd::firmware;  // NOLINT: benchmark file

constexpr int kSamples = 4096;

// Generated in double, then rounded to Real (the firmware's scalar type, real.hpp).
struct Excitation {
  Excitation() {
    for (int k = 0; k < kSamples; ++k) {
      v.push_back(static_cast<Real>(12.0 * std::sin(2.0 * 3.14159 * 2.0 * k * 1e-3) +
                                    0.3 * std::sin(0.7 * k)));
      f.push_back(static_cast<Real>(800.0 * std::sin(2.0 * 3.14159 * 0.5 * k * 1e-3)));
    }
  }
  std::vector<Real> v, f;
};

void StepAndInvert(benchmark::State& state, const mrd::CoefficientTable& table) {
  const Excitation ex;
  ModelRuntime rt;
  Inverter inv;
  if (rt.Configure(table) != mrd::Error::kOk || inv.Configure(table) != mrd::Error::kOk) {
    state.SkipWithError("table refused");
    return;
  }
  Real E = 0;
  int k = 0;
  for (auto _ : state) {
    rt.Begin(ex.v[k], 0);
    E = inv.Solve(rt.history(), ex.f[k], ex.v[k]).E;
    benchmark::DoNotOptimize(rt.Finish(E));
    k = (k + 1) & (kSamples - 1);
  }
}

void BM_ModelStepAndInversion(benchmark::State& state) { StepAndInvert(state, kBuiltinTable); }
BENCHMARK(BM_ModelStepAndInversion);

void BM_ModelStep(benchmark::State& state) {
  const Excitation ex;
  ModelRuntime rt;
  if (rt.Configure(kBuiltinTable) != mrd::Error::kOk) {
    state.SkipWithError("table refused");
    return;
  }
  int k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(rt.Step(ex.v[k], 0, 1));
    k = (k + 1) & (kSamples - 1);
  }
}
BENCHMARK(BM_ModelStep);

void BM_ControllerUpdate(benchmark::State& state) {
  const Excitation ex;
  Controller c;
  if (c.Configure(kBuiltinTable, ControllerConfig{}) != mrd::Error::kOk) {
    state.SkipWithError("table refused");
    return;
  }
  SensorFrame frame;
  std::int64_t now = 0;
  int k = 0;
  for (auto _ : state) {
    now += 1'000'000;
    frame[Input::kVelocity] = {static_cast<double>(ex.v[k]), now};
    frame[Input::kDemand] = {static_cast<double>(ex.f[k]), now};
    benchmark::DoNotOptimize(c.Update(frame, IoStatus::kOk, false, now, 1e-3));
    k = (k + 1) & (kSamples - 1);
  }
}
BENCHMARK(BM_ControllerUpdate);

// One HIL plant period of the quarter car on a class C road (10 RK4 substeps; the budget of the
// harness's lockstep speed): real time is 1 ms per step.
void BM_QuarterCarStep(benchmark::State& state) {
  mrd::QuarterCarPlant plant(mrd::SpencerParams::Paper(), mrd::QuarterCarParams{},
                             mrd::RoadParams{}, 1e-3);
  double volts = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(plant.Step(volts));
    volts = volts > 2.0 ? 0.0 : volts + 0.01;
  }
}
BENCHMARK(BM_QuarterCarStep);

}  // namespace

int main(int argc, char** argv) {
  static mrd::CoefficientTable file_table;
  if (const char* path = std::getenv("MRD_BENCH_TABLE")) {
    const auto t = platform::LoadTableFile(path);
    if (!t.ok()) {
      std::fprintf(stderr, "error: %s: %s\n", path, mrd::ErrorName(t.error()));
      return 2;
    }
    file_table = t.value();
    benchmark::RegisterBenchmark("BM_ModelStepAndInversion/file",
                                 [](benchmark::State& s) { StepAndInvert(s, file_table); });
  }
  benchmark::AddCustomContext("mrd_real", sizeof(Real) == sizeof(float) ? "float" : "double");
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
