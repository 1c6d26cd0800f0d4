// The loop with the per-period log on allocates nothing: this executable replaces the
// allocator (tests/support/alloc_counter.hpp); the guard counts every thread's allocations, so
// the log's writer thread (draining, encoding, writing blocks) is covered too.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include "host/test_util.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/platform/period_log.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"
#include "support/alloc_counter.hpp"  // replaces the allocator of this executable
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;

TEST(LogNoAllocationTest, LockstepRunWithTheLogOnAllocatesNothing) {
  test::TempDir dir;
  platform::LogConfig config;
  config.path = dir.File("noalloc.mrdlog");
  config.block_records = 64;
  LockstepClock clock;
  SimulatedDamper plant(SpencerParams::Paper(), SimulationConfig{}, clock, kPeriod);
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk);
  Telemetry telemetry;
  Loop loop(clock, plant, plant, controller, telemetry, kPeriod);
  platform::PeriodLog log;
  log.Start(config, kPeriod, "no-alloc test");
  loop.SetObserver(&log);
  std::atomic<bool> stop{false};
  std::uint64_t allocations = 0;
  std::uint64_t written_guarded = 0;
  {
    test::AllocationGuard guard;
    loop.Run(stop, 3'000'000'000);
    // Let the writer drain and write its full blocks while still guarded (bounded wait).
    for (int i = 0; i < 20000 && log.stats().written < 3000 - 3000 % 64; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    written_guarded = log.stats().written;
    allocations = guard.count();
  }
  log.Stop();
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(loop.stats().ticks, 3000U);
  EXPECT_EQ(log.stats().written, 3000U);
  EXPECT_EQ(log.stats().dropped, 0U);
  EXPECT_GE(written_guarded, 3000U - 3000U % 64);  // the writer really wrote while guarded
}

}  // namespace
}  // namespace mrd::firmware
