// Google Benchmark: one control period's computation on the compiled-in table, in the
// firmware's scalar type Real (double; float with MRD_REAL=float: the context line "mrd_real").
//   BM_ModelStepAndInversion: Begin + Inverter::Solve + Finish (the model/inversion core)
//   BM_ModelStep:             Begin + Finish (forward model only)
//   BM_ControllerUpdate:      watchdog + law + inversion + model (Controller::Update)
//   BM_ProfileCanPeriod:      one period's CAN frames through a device profile's codec: the two
//                             sensor messages found, checked and decoded, the command message
//                             built and sealed (mrd-native; MRD_BENCH_PROFILE=FILE adds another)
// MRD_BENCH_TABLE=FILE adds BM_ModelStepAndInversion/file on that exported table (e.g. the
// NEES model with its low-pass command regressor).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "mrd/common/quarter_car.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/inverter.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "mrd/firmware/table_file.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/frame_codec.hpp"

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
    E = inv.Solve(rt.history(), ex.f[k], E).E;
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
    frame.velocity = {static_cast<double>(ex.v[k]), now};
    frame.demand = {static_cast<double>(ex.f[k]), now};
    benchmark::DoNotOptimize(c.Update(frame, IoStatus::kOk, false, now, 1e-3));
    k = (k + 1) & (kSamples - 1);
  }
}
BENCHMARK(BM_ControllerUpdate);

void ProfilePeriod(benchmark::State& state, const mrd::profile::CanProfile& p) {
  using mrd::profile::CanIn;
  using mrd::profile::CanOut;
  mrd::profile::FrameCodec tx(p), rx(p);
  const auto in = [&](CanIn r) { return p.inputs[static_cast<std::size_t>(r)]; };
  const auto out = [&](CanOut r) { return p.outputs[static_cast<std::size_t>(r)]; };
  // The sensor frames of kSamples periods, built once.
  std::vector<can_frame> motion(kSamples), force(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    tx.Begin(in(CanIn::kVelocity).message, &motion[k]);
    (void)tx.Set(&motion[k], in(CanIn::kVelocity), 10.0 * std::sin(0.01 * k));
    (void)tx.Set(&motion[k], in(CanIn::kDisplacement), 0.5 * std::cos(0.01 * k));
    tx.Seal(in(CanIn::kVelocity).message, &motion[k]);
    tx.Begin(in(CanIn::kDemand).message, &force[k]);
    (void)tx.Set(&force[k], in(CanIn::kDemand), 500.0 * std::sin(0.003 * k));
    tx.Seal(in(CanIn::kDemand).message, &force[k]);
  }
  const int cmd = out(CanOut::kCommand).message;
  int k = 0;
  double sum = 0.0;
  for (auto _ : state) {
    for (const can_frame* f : {&motion[k], &force[k]}) {
      const int m = rx.Find(*f);
      if (rx.Check(m, *f) == mrd::protocol::can::Reject::kNone) {
        double v = 0.0;
        (void)rx.Get(*f, m == in(CanIn::kVelocity).message ? in(CanIn::kVelocity) : in(CanIn::kDemand), &v);
        sum += v;
      }
    }
    can_frame c{};
    tx.Begin(cmd, &c);
    (void)tx.Set(&c, out(CanOut::kCommand), 1.0 + 0.5 * std::sin(0.002 * k));
    if (out(CanOut::kEnable).mapped()) (void)tx.Set(&c, out(CanOut::kEnable), 1.0);
    if (out(CanOut::kEcho).mapped()) (void)tx.Set(&c, out(CanOut::kEcho), k & 255);
    tx.Seal(cmd, &c);
    benchmark::DoNotOptimize(c);
    k = (k + 1) % kSamples;
    rx.ResetCounters();  // frames of the table repeat every kSamples periods
  }
  benchmark::DoNotOptimize(sum);
}

void BM_ProfileCanPeriod(benchmark::State& state) {
  ProfilePeriod(state, mrd::profile::NativeCanProfile());
}
BENCHMARK(BM_ProfileCanPeriod);

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

// MRD_BENCH_PROFILE=FILE: the same period on another profile (e.g. the test driver's).
[[maybe_unused]] const bool kProfileFromEnv = [] {
  const char* path = std::getenv("MRD_BENCH_PROFILE");
  if (path == nullptr) return false;
  static mrd::profile::CanProfile profile;
  std::string error;
  if (!mrd::profile::LoadCanProfile(path, &profile, &error)) {
    std::fprintf(stderr, "MRD_BENCH_PROFILE: %s\n", error.c_str());
    return false;
  }
  benchmark::RegisterBenchmark("BM_ProfileCanPeriod/file",
                               [](benchmark::State& st) { ProfilePeriod(st, profile); });
  return true;
}();

}  // namespace

int main(int argc, char** argv) {
  static mrd::CoefficientTable file_table;
  if (const char* path = std::getenv("MRD_BENCH_TABLE")) {
    const auto t = LoadTableFile(path);
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
