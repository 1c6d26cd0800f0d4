// Google Benchmark: the step cost of each control law, on the compiled-in table.
//   BM_ControlLaw/NAME:           ControlLaw::Update alone (the decision rule)
//   BM_ControllerUpdateLaw/NAME:  Controller::Update with that law (watchdog, input checks,
//                                 law, inversion for the force laws, model)
// Every [control] law but clipped-optimal (bench_clipped_optimal.cpp: it needs its gains).
// The inputs follow a quarter-car-like excitation: body 1.2 Hz, wheel 11 Hz, so every branch
// of each rule is taken.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <vector>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"

namespace {

using namespace mrd::firmware;  // NOLINT: benchmark file

constexpr int kSamples = 4096;
constexpr double kTwoPi = 6.283185307179586;

struct ChassisExcitation {
  ChassisExcitation() {
    for (int k = 0; k < kSamples; ++k) {
      const double t = k * 1e-3;
      const double vb = 8.0 * std::sin(kTwoPi * 1.2 * t);  // [cm/s]
      const double ab = 8.0 * kTwoPi * 1.2 * std::cos(kTwoPi * 1.2 * t) +
                        150.0 * std::sin(kTwoPi * 11.0 * t);                  // [cm/s^2]
      const double vw = 20.0 * std::sin(kTwoPi * 11.0 * t + 0.4) + 0.5 * vb;  // [cm/s]
      body_velocity.push_back(vb);
      body_acceleration.push_back(ab);
      wheel_velocity.push_back(vw);
      v.push_back(0.7 * (vb - vw));  // damper velocity through a 0.7 motion ratio [cm/s]
      // A dissipative force demand [N] (force law); read as mV by the open-loop law.
      demand.push_back(300.0 * std::tanh(v.back() / 2.0) + 600.0);
    }
  }
  std::vector<double> v, body_velocity, body_acceleration, wheel_velocity, demand;
};

const ControlMode kModes[] = {ControlMode::kForceTracking,
                              ControlMode::kOpenLoop,
                              ControlMode::kConstantVoltage,
                              ControlMode::kSkyhookOnOff,
                              ControlMode::kSkyhookContinuous,
                              ControlMode::kGroundhook,
                              ControlMode::kGroundhookOnOff,
                              ControlMode::kHybrid,
                              ControlMode::kAdd,
                              ControlMode::kSkyhookAdd};

void BM_ControlLaw(benchmark::State& state, ControlMode mode) {
  const ChassisExcitation ex;
  ControlLawConfig c;
  c.mode = mode;
  ControlLaw law;
  law.Configure(c, 0.0, 2.25);
  int k = 0;
  for (auto _ : state) {
    ControlInputs in;
    in.v = static_cast<Real>(ex.v[static_cast<std::size_t>(k)]);
    in.demand = static_cast<Real>(ex.demand[static_cast<std::size_t>(k)]);
    in.body_velocity = static_cast<Real>(ex.body_velocity[static_cast<std::size_t>(k)]);
    in.wheel_velocity = static_cast<Real>(ex.wheel_velocity[static_cast<std::size_t>(k)]);
    in.body_acceleration = static_cast<Real>(ex.body_acceleration[static_cast<std::size_t>(k)]);
    benchmark::DoNotOptimize(law.Update(in));
    k = (k + 1) & (kSamples - 1);
  }
}

void BM_ControllerUpdateLaw(benchmark::State& state, ControlMode mode) {
  const ChassisExcitation ex;
  ControllerConfig config;
  config.law.mode = mode;
  Controller c;
  if (c.Configure(kBuiltinTable, config) != mrd::Error::kOk) {
    state.SkipWithError("table refused");
    return;
  }
  SensorFrame frame;
  std::int64_t now = 0;
  int k = 0;
  for (auto _ : state) {
    now += 1'000'000;
    const auto i = static_cast<std::size_t>(k);
    frame[Input::kVelocity] = {ex.v[i], now};
    frame[Input::kDemand] = {ex.demand[i], now};
    frame[Input::kBodyVelocity] = {ex.body_velocity[i], now};
    frame[Input::kWheelVelocity] = {ex.wheel_velocity[i], now};
    frame[Input::kBodyAcceleration] = {ex.body_acceleration[i], now};
    benchmark::DoNotOptimize(c.Update(frame, IoStatus::kOk, false, now, 1e-3));
    k = (k + 1) & (kSamples - 1);
  }
}

const bool kRegistered = [] {
  for (const ControlMode mode : kModes) {
    const std::string name = ControlModeName(mode);
    benchmark::RegisterBenchmark(("BM_ControlLaw/" + name).c_str(), BM_ControlLaw, mode);
    benchmark::RegisterBenchmark(("BM_ControllerUpdateLaw/" + name).c_str(), BM_ControllerUpdateLaw,
                                 mode);
  }
  return true;
}();

}  // namespace
