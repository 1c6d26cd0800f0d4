// Google Benchmark: one loop period with N damper channels (loop.hpp), 1, 2, 4 and 8: every
// channel's read, update (force tracking on the compiled-in table), write and telemetry, the
// fault policy (kAll) and, with BodyLaw, a body law over all channels. The channels share one
// model of the table (shared_model.hpp), as the firmware runs them; OwnModels gives each
// channel a copy of its own (as before the model was shared). The sources replay a stored
// excitation and the drivers take the command: the figure is the firmware's work, no plant.
// Goal: 4 channels within 4x one channel.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/loop.hpp"

namespace {

using namespace mrd::firmware;  // NOLINT: benchmark file

constexpr int kSamples = 4096;

// Velocity and demand from a stored excitation, phase-shifted per channel, stamped now.
class ReplaySource final : public SensorSource {
 public:
  explicit ReplaySource(int phase) : k_(phase & (kSamples - 1)) {
    for (int k = 0; k < kSamples; ++k) {
      v_.push_back(12.0 * std::sin(2.0 * 3.14159 * 2.0 * k * 1e-3) + 0.3 * std::sin(0.7 * k));
      f_.push_back(800.0 * std::sin(2.0 * 3.14159 * 0.5 * k * 1e-3));
    }
  }
  IoStatus Read(const IoTime& t, SensorFrame* frame) override {
    (*frame)[Input::kVelocity] = {v_[k_], t.loop_ns};
    (*frame)[Input::kDemand] = {f_[k_], t.loop_ns};
    (*frame)[Input::kBodyVelocity] = {0.5 * v_[k_], t.loop_ns};
    k_ = (k_ + 1) & (kSamples - 1);
    return IoStatus::kOk;
  }

 private:
  std::vector<double> v_, f_;
  int k_;
};

class SinkDriver final : public CurrentDriver {
 public:
  IoStatus Command(const IoTime&, double volts) override {
    benchmark::DoNotOptimize(volts);
    return IoStatus::kOk;
  }
  IoStatus EnterSafeState(const IoTime&, double volts) override { return Command({}, volts); }
};

// Each channel's demand from every channel's body velocity (the shape of modal skyhook).
class BodyDemands final : public BodyLaw {
 public:
  void Apply(SensorFrame* const* frames, std::size_t n, std::int64_t now_ns) override {
    double heave = 0.0;
    for (std::size_t i = 0; i < n; ++i) heave += (*frames[i])[Input::kBodyVelocity].value;
    heave /= static_cast<double>(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double vb = (*frames[i])[Input::kBodyVelocity].value;
      (*frames[i])[Input::kDemand] = Stamped{20.0 * (0.7 * heave + 0.3 * vb), now_ns};
    }
  }
};

void LoopPeriod(benchmark::State& state, bool body_law, bool own_models) {
  const auto n = static_cast<std::size_t>(state.range(0));
  mrd::Error error = mrd::Error::kOk;
  const auto shared = SharedModel::Load(kBuiltinTable, &error);
  std::vector<std::unique_ptr<ReplaySource>> sources;
  std::vector<SinkDriver> drivers(n);
  std::vector<Controller> controllers(n);
  std::vector<Telemetry> telemetry(n);
  std::vector<std::unique_ptr<Channel>> channels;
  std::vector<Channel*> list;
  for (std::size_t i = 0; i < n; ++i) {
    sources.push_back(std::make_unique<ReplaySource>(static_cast<int>(i) * 517));
    const ConfigureStatus status = own_models
                                       ? controllers[i].Configure(kBuiltinTable, ControllerConfig{})
                                       : controllers[i].Configure(shared, ControllerConfig{});
    if (status != mrd::Error::kOk) {
      state.SkipWithError("table refused");
      return;
    }
    channels.push_back(
        std::make_unique<Channel>(*sources[i], drivers[i], controllers[i], telemetry[i]));
    list.push_back(channels.back().get());
  }
  LockstepClock clock;
  Loop loop(clock, list.data(), list.size(), FaultPolicy::kAll, 1'000'000);
  BodyDemands law;
  if (body_law) loop.SetBodyLaw(&law);
  for (auto _ : state) {
    clock.Advance(1'000'000);
    loop.Tick(IoTime{clock.Now(), clock.Now()});
  }
  state.counters["channels"] = static_cast<double>(n);
}

void BM_LoopPeriod(benchmark::State& state) { LoopPeriod(state, false, false); }
BENCHMARK(BM_LoopPeriod)->Arg(1)->Arg(2)->Arg(4)->Arg(8);
void BM_LoopPeriodOwnModels(benchmark::State& state) { LoopPeriod(state, false, true); }
BENCHMARK(BM_LoopPeriodOwnModels)->Arg(1)->Arg(2)->Arg(4)->Arg(8);
void BM_LoopPeriodBodyLaw(benchmark::State& state) { LoopPeriod(state, true, false); }
BENCHMARK(BM_LoopPeriodBodyLaw)->Arg(4);

}  // namespace
