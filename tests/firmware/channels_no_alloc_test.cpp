// Four damper channels on one loop allocate nothing per period: reads, the body law, updates,
// writes, the fault passed between channels (FaultPolicy::kAll: safe states entered and left on
// every channel) and the telemetry. The executable replaces the allocator
// (tests/support/alloc_counter.hpp).
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <memory>

#include "fakes.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"
#include "support/alloc_counter.hpp"  // replaces the allocator of this executable
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;
constexpr std::size_t kCorners = 4;

// Each corner's demand becomes the mean of the four (a law over the whole body).
class MeanDemand final : public BodyLaw {
 public:
  void Apply(SensorFrame* const* frames, std::size_t n, std::int64_t now_ns) override {
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) sum += (*frames[i])[Input::kDemand].value;
    for (std::size_t i = 0; i < n; ++i) {
      (*frames[i])[Input::kDemand] = Stamped{sum / static_cast<double>(n), now_ns};
    }
  }
};

std::uint64_t AllocationsWithFourChannels(FaultPolicy policy, ControlMode mode) {
  LockstepClock clock;
  ControllerConfig config;
  config.law.mode = mode;
  std::array<std::unique_ptr<SimulatedDamper>, kCorners> plants;
  std::array<std::unique_ptr<test::FaultySource>, kCorners> sources;
  std::array<std::unique_ptr<test::FaultyDriver>, kCorners> drivers;
  std::array<Controller, kCorners> controllers;
  std::array<Telemetry, kCorners> telemetry;
  std::array<std::unique_ptr<Channel>, kCorners> channels;
  std::array<Channel*, kCorners> list{};
  Error error = Error::kOk;
  const auto shared = SharedModel::Load(test::DemoDamperTable(), &error);  // one table, 4 corners
  EXPECT_EQ(error, Error::kOk);
  for (std::size_t i = 0; i < kCorners; ++i) {
    plants[i] = std::make_unique<SimulatedDamper>(SpencerParams::Paper(), SimulationConfig{}, clock,
                                                  kPeriod);
    sources[i] = std::make_unique<test::FaultySource>(*plants[i]);
    drivers[i] = std::make_unique<test::FaultyDriver>(*plants[i]);
    EXPECT_EQ(controllers[i].Configure(shared, config), Error::kOk);
    channels[i] = std::make_unique<Channel>(*sources[i], *drivers[i], controllers[i], telemetry[i]);
    list[i] = channels[i].get();
  }
  sources[1]->nan_velocity = {1000, 1010};
  sources[2]->stall = {2000, 2050};
  sources[3]->bus_fault = {3000, 3005};
  drivers[0]->fail_from = 4000;
  drivers[0]->fail_to = 4001;
  MeanDemand law;
  Loop loop(clock, list.data(), list.size(), policy, kPeriod);
  loop.SetBodyLaw(&law);
  test::AllocationGuard guard;
  for (int k = 0; k < 5000; ++k) {
    clock.Advance(kPeriod);
    loop.Tick(clock.Now());
  }
  loop.Shutdown();
  const std::uint64_t n = guard.count();
  for (std::size_t i = 0; i < kCorners; ++i) {
    // The faults happened: each channel's own, and under kAll the others' too.
    const std::uint64_t entries = policy == FaultPolicy::kAll ? 3U : 1U;
    EXPECT_GE(loop.channel(i).stats().watchdog.entries, entries) << i;
  }
  return n;
}

TEST(ChannelsNoAllocationTest, FourChannelsUnderEachPolicyAllocateNothing) {
  for (const FaultPolicy policy : {FaultPolicy::kAll, FaultPolicy::kChannel}) {
    for (const ControlMode mode : {ControlMode::kForceTracking, ControlMode::kSkyhookContinuous}) {
      EXPECT_EQ(AllocationsWithFourChannels(policy, mode), 0U);
    }
  }
}

TEST(ChannelsNoAllocationTest, GuardCatchesADeliberateAllocation) {
  test::AllocationGuard guard;
  auto p = std::make_unique<int>(7);
  asm volatile("" : : "g"(p.get()) : "memory");
  EXPECT_GE(guard.count(), 1U);
}

}  // namespace
}  // namespace mrd::firmware
