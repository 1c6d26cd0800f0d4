// Cost of the full car (mrd/sim/full_car.hpp) per 1 ms period: the car's Step alone (10 RK4
// substeps, road and damper forces given), the two-track road's Advance alone (6 tracks of 256
// components), and both together as a harness would run them.
#include <benchmark/benchmark.h>

#include "mrd/sim/full_car.hpp"
#include "mrd/sim/two_track_road.hpp"

namespace {

constexpr double kPeriod = 1e-3;  // [s]
constexpr double kSpeed = 20.0;   // [m/s]

mrd::CornerValues Dashpot(const mrd::FullCarSample& s) {
  mrd::CornerValues f;
  for (int i = 0; i < 4; ++i) f[i] = 19.0 * s.corner[i].damper_v_cm_s;  // 0 V-like, N s/cm
  return f;
}

void BM_FullCarStep(benchmark::State& state) {
  mrd::FullCar car{mrd::FullCarParams{}};
  const mrd::CornerValues road{0.01, -0.005, 0.002, 0.0}, rate{0.1, -0.2, 0.05, 0.0};
  for (auto _ : state) {
    benchmark::DoNotOptimize(car.Step(kPeriod, road, rate, Dashpot(car.Sample())));
  }
}
BENCHMARK(BM_FullCarStep);

void BM_TwoTrackRoadAdvance(benchmark::State& state) {
  mrd::TwoTrackRoad road(mrd::TwoTrackRoadParams{}, kSpeed * kPeriod);
  for (auto _ : state) {
    road.Advance();
    benchmark::DoNotOptimize(road.heights_m());
  }
}
BENCHMARK(BM_TwoTrackRoadAdvance);

void BM_FullCarOnRoad(benchmark::State& state) {
  mrd::TwoTrackRoad road(mrd::TwoTrackRoadParams{}, kSpeed * kPeriod);
  mrd::FullCar car{mrd::FullCarParams{}};
  mrd::CornerValues rate;
  for (auto _ : state) {
    road.Advance();
    for (int i = 0; i < 4; ++i) rate[i] = kSpeed * road.slopes()[i];
    benchmark::DoNotOptimize(car.Step(kPeriod, road.heights_m(), rate, Dashpot(car.Sample())));
  }
}
BENCHMARK(BM_FullCarOnRoad);

}  // namespace

BENCHMARK_MAIN();
