// GrantClock: the loop's time follows the harness's grants; a missing grant is a fault.
#include "mrd/firmware/grant_clock.hpp"

#include <gtest/gtest.h>

#include <deque>

namespace mrd::firmware {
namespace {

// Hands out queued grants; an empty queue is a timeout.
class QueuedGrants final : public TimeGrantSource {
 public:
  bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) override {
    last_timeout_ns = timeout_ns;
    ++waits;
    if (grants.empty()) return false;
    *t_ns = grants.front();
    grants.pop_front();
    return true;
  }
  std::deque<std::int64_t> grants;
  std::int64_t last_timeout_ns = 0;
  int waits = 0;
};

TEST(GrantClockTest, TimeAdvancesOnlyWithGrants) {
  QueuedGrants src;
  GrantClock clock(src, 50'000'000, 0);  // no longer first wait
  EXPECT_EQ(clock.Now(), 0);
  src.grants = {1'000'000};
  clock.SleepUntil(1'000'000);
  EXPECT_EQ(clock.Now(), 1'000'000);
  EXPECT_EQ(clock.grants(), 1U);
  EXPECT_EQ(src.last_timeout_ns, 50'000'000);
}

TEST(GrantClockTest, WaitsThroughEarlierGrantsUntilTheDeadline) {
  QueuedGrants src;
  GrantClock clock(src, 1);
  src.grants = {1'000'000, 2'000'000, 3'000'000, 4'000'000};
  clock.SleepUntil(3'000'000);
  EXPECT_EQ(clock.Now(), 3'000'000);
  EXPECT_EQ(clock.grants(), 3U);
  EXPECT_EQ(src.grants.size(), 1U);  // the next grant is left for the next period
}

TEST(GrantClockTest, ReturnsAtOnceWhenTheDeadlineHasPassed) {
  QueuedGrants src;
  GrantClock clock(src, 1);
  src.grants = {5'000'000};
  clock.SleepUntil(2'000'000);  // grant 5 ms > 2 ms: one wait
  EXPECT_EQ(clock.Now(), 5'000'000);
  const int waits = src.waits;
  clock.SleepUntil(4'000'000);
  EXPECT_EQ(src.waits, waits);
}

TEST(GrantClockTest, AMissingGrantReturnsAtTheLastGrantAndIsCounted) {
  QueuedGrants src;
  GrantClock clock(src, 1);
  clock.SleepUntil(1'000'000);
  EXPECT_EQ(clock.Now(), 0);  // only grants move time
  EXPECT_EQ(clock.missed_grants(), 1U);
  src.grants = {2'000'000};
  clock.SleepUntil(2'000'000);
  EXPECT_EQ(clock.missed_grants(), 1U);
  EXPECT_EQ(clock.grants(), 1U);
}

TEST(GrantClockTest, GrantsNeverMoveTimeBackwards) {
  QueuedGrants src;
  GrantClock clock(src, 1);
  src.grants = {3'000'000, 1'000'000};
  clock.SleepUntil(3'000'000);
  src.grants = {1'000'000, 4'000'000};
  clock.SleepUntil(4'000'000);
  EXPECT_EQ(clock.Now(), 4'000'000);
}

}  // namespace
}  // namespace mrd::firmware

namespace mrd::firmware {
namespace {

// Issue 10: start-up — the first grant is awaited longer (the harness may start later); after
// it, the normal timeout.
TEST(GrantClockTest, FirstGrantGetsTheStartUpTimeout) {
  QueuedGrants src;
  GrantClock clock(src, 20'000'000, 3'000'000'000);
  src.grants = {1'000'000};
  clock.SleepUntil(1'000'000);
  EXPECT_EQ(src.last_timeout_ns, 3'000'000'000);
  clock.SleepUntil(2'000'000);  // no grant: missed with the normal timeout
  EXPECT_EQ(src.last_timeout_ns, 20'000'000);
  EXPECT_EQ(clock.missed_grants(), 1U);
  EXPECT_EQ(clock.Now(), 1'000'000);
}

}  // namespace
}  // namespace mrd::firmware
