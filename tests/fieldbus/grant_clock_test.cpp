// GrantClock: the loop's time follows the harness's grants and never wall time: a late grant
// is waited for (no missed period), and only a harness gone for the whole give-up time (or a
// stop request) halts the clock, which ends the loop.
#include "mrd/firmware/io/grant_clock.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <deque>
#include <thread>

namespace mrd::firmware {
namespace {

// Hands out queued grants; with the queue empty a wait lasts its whole timeout (as a device
// that hears nothing) and returns false. late_waits: that many waits time out before the
// queue is served (a harness that is slow or stopped for a while).
class QueuedGrants final : public TimeGrantSource {
 public:
  bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) override {
    last_timeout_ns = timeout_ns;
    ++waits;
    if (grants.empty() || late_waits > 0) {
      if (late_waits > 0) --late_waits;
      std::this_thread::sleep_for(std::chrono::nanoseconds(timeout_ns));
      return false;
    }
    *t_ns = grants.front();
    grants.pop_front();
    return true;
  }
  std::deque<std::int64_t> grants;
  int late_waits = 0;
  std::int64_t last_timeout_ns = 0;
  int waits = 0;
};

constexpr std::int64_t kGiveUp = 10'000'000'000;  // 10 s: never reached by a passing test

TEST(GrantClockTest, TimeAdvancesOnlyWithGrants) {
  QueuedGrants src;
  GrantClock clock(src, kGiveUp);
  EXPECT_EQ(clock.Now(), 0);
  src.grants = {1'000'000};
  clock.SleepUntil(1'000'000);
  EXPECT_EQ(clock.Now(), 1'000'000);
  EXPECT_EQ(clock.grants(), 1U);
  EXPECT_FALSE(clock.Halted());
  EXPECT_LE(src.last_timeout_ns, GrantClock::kSliceNs);  // sliced: a stop request is seen
}

TEST(GrantClockTest, WaitsThroughEarlierGrantsUntilTheDeadline) {
  QueuedGrants src;
  GrantClock clock(src, kGiveUp);
  src.grants = {1'000'000, 2'000'000, 3'000'000, 4'000'000};
  clock.SleepUntil(3'000'000);
  EXPECT_EQ(clock.Now(), 3'000'000);
  EXPECT_EQ(clock.grants(), 3U);
  EXPECT_EQ(src.grants.size(), 1U);  // the next grant is left for the next period
}

TEST(GrantClockTest, ReturnsAtOnceWhenTheDeadlineHasPassed) {
  QueuedGrants src;
  GrantClock clock(src, kGiveUp);
  src.grants = {5'000'000};
  clock.SleepUntil(2'000'000);  // grant 5 ms > 2 ms: one wait
  EXPECT_EQ(clock.Now(), 5'000'000);
  const int waits = src.waits;
  clock.SleepUntil(4'000'000);
  EXPECT_EQ(src.waits, waits);
}

TEST(GrantClockTest, GrantsNeverMoveTimeBackwards) {
  QueuedGrants src;
  GrantClock clock(src, kGiveUp);
  src.grants = {3'000'000, 1'000'000};
  clock.SleepUntil(3'000'000);
  src.grants = {1'000'000, 4'000'000};
  clock.SleepUntil(4'000'000);
  EXPECT_EQ(clock.Now(), 4'000'000);
}

// A grant that comes late on the wall clock (a loaded machine, a harness stopped for 150 ms)
// is waited for: time advances to it, nothing is missed, the clock runs on.
TEST(GrantClockTest, ALateGrantIsWaitedForNotMissed) {
  QueuedGrants src;
  GrantClock clock(src, kGiveUp);
  src.grants = {1'000'000};
  clock.SleepUntil(1'000'000);
  src.late_waits = 3;  // three empty slices first: 150 ms with 50 ms slices
  src.grants = {2'000'000};
  clock.SleepUntil(2'000'000);
  EXPECT_EQ(clock.Now(), 2'000'000);
  EXPECT_EQ(clock.grants(), 2U);
  EXPECT_FALSE(clock.Halted());
  EXPECT_FALSE(clock.gave_up());
  EXPECT_EQ(src.late_waits, 0);
}

// No grant for the whole give-up time: the harness is gone; the clock halts at the last
// granted time (the loop then ends) instead of returning ticks without time.
TEST(GrantClockTest, NoGrantForTheGiveUpTimeHaltsTheClock) {
  QueuedGrants src;
  GrantClock clock(src, 30'000'000);
  src.grants = {1'000'000};
  clock.SleepUntil(1'000'000);
  clock.SleepUntil(2'000'000);
  EXPECT_TRUE(clock.Halted());
  EXPECT_TRUE(clock.gave_up());
  EXPECT_EQ(clock.Now(), 1'000'000);  // only grants move time
  EXPECT_EQ(clock.grants(), 1U);
  const int waits = src.waits;
  clock.SleepUntil(3'000'000);  // halted: no more waiting
  EXPECT_EQ(src.waits, waits);
}

// A stop request (SIGTERM) ends a wait for a grant within one slice.
TEST(GrantClockTest, AStopRequestHaltsTheWait) {
  QueuedGrants src;
  std::atomic<bool> stop{false};
  GrantClock clock(src, kGiveUp, &stop);
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    stop.store(true);
  });
  clock.SleepUntil(1'000'000);
  stopper.join();
  EXPECT_TRUE(clock.Halted());
  EXPECT_FALSE(clock.gave_up());
  EXPECT_EQ(clock.Now(), 0);
}

}  // namespace
}  // namespace mrd::firmware
