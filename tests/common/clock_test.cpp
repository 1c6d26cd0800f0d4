// mrd/common/clock.hpp: the one monotonic clock and its absolute-deadline sleep.
#include "mrd/common/clock.hpp"

#include <gtest/gtest.h>
#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <cerrno>
#include <thread>

namespace {

using mrd::common::MonotonicNs;
using mrd::common::SleepUntilNs;

std::atomic<int> g_signals{0};
void CountSignal(int) { g_signals.fetch_add(1); }

TEST(Clock, MonotonicNsNeverGoesBackwards) {
  std::int64_t last = MonotonicNs();
  for (int i = 0; i < 1000; ++i) {
    const std::int64_t now = MonotonicNs();
    EXPECT_GE(now, last);
    last = now;
  }
  EXPECT_GT(last, 0);
}

TEST(Clock, APastDeadlineReturnsAtOnceWithoutError) {
  const std::int64_t now = MonotonicNs();
  EXPECT_EQ(SleepUntilNs(now - 1'000'000'000), 0);
  EXPECT_EQ(SleepUntilNs(0), 0);
  EXPECT_EQ(SleepUntilNs(-5), 0);  // negative: long past, not EINVAL
  EXPECT_EQ(SleepUntilNs(now), 0);
}

TEST(Clock, SleepsUntilTheDeadline) {
  const std::int64_t deadline = MonotonicNs() + 2'000'000;
  EXPECT_EQ(SleepUntilNs(deadline), 0);
  EXPECT_GE(MonotonicNs(), deadline);  // order, not duration: never returns early
}

TEST(Clock, ABadClockIdReportsTheError) {
  // Reported at once (the copies this replaced spun forever on EINVAL).
  EXPECT_EQ(SleepUntilNs(MonotonicNs() + 1'000'000, static_cast<clockid_t>(-1)), EINVAL);
  EXPECT_EQ(SleepUntilNs(MonotonicNs() + 1'000'000, static_cast<clockid_t>(12345)), EINVAL);
}

// One sleep towards deadline_ns from now while another thread sends SIGUSR1 every 10 ms (at
// most 5); returns clock_nanosleep's result, the wake time and the deadline.
struct InterruptedSleep {
  int result;
  std::int64_t woke_ns, deadline_ns;
};
InterruptedSleep SleepWhileSignalled(std::int64_t sleep_ns) {
  const pthread_t sleeper = pthread_self();
  std::atomic<bool> started{false}, done{false};
  std::thread signaller([&] {
    started = true;
    for (int i = 0; i < 5 && !done.load(); ++i) {
      const timespec ts{0, 10'000'000};
      nanosleep(&ts, nullptr);
      if (!done.load()) pthread_kill(sleeper, SIGUSR1);
    }
  });
  while (!started.load()) std::this_thread::yield();
  const std::int64_t deadline = MonotonicNs() + sleep_ns;
  const int r = SleepUntilNs(deadline);
  const std::int64_t woke = MonotonicNs();
  done = true;
  signaller.join();
  return {r, woke, deadline};
}

TEST(Clock, ASignalResumesTheSleepTowardsTheSameDeadline) {
  struct sigaction sa {};
  sa.sa_handler = CountSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: clock_nanosleep returns EINTR on each signal
  struct sigaction old {};
  ASSERT_EQ(sigaction(SIGUSR1, &sa, &old), 0);

  // The sleep must be interrupted for the test to mean anything: on a busy machine the
  // signaller may not run before a short deadline, so the sleep gets longer until a signal
  // arrived during it (each attempt asserts the same).
  int signals = 0;
  for (std::int64_t sleep_ns = 200'000'000; sleep_ns <= 3'200'000'000 && signals == 0;
       sleep_ns *= 4) {
    g_signals = 0;
    const InterruptedSleep s = SleepWhileSignalled(sleep_ns);
    signals = g_signals.load();
    EXPECT_EQ(s.result, 0);
    EXPECT_GE(s.woke_ns, s.deadline_ns);  // ended at the deadline, not at a signal
  }
  sigaction(SIGUSR1, &old, nullptr);
  EXPECT_GE(signals, 1);  // the sleep was interrupted at least once
}

}  // namespace
