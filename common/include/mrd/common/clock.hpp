#pragma once
// The one monotonic clock of every side (firmware, HIL, local CAN bus, simulated GPIO, tests):
// CLOCK_MONOTONIC in nanoseconds and an absolute-deadline sleep. Real-time safe: no
// allocation, no exceptions, one system call per attempt.

#include <cstdint>
#include <ctime>

namespace mrd::common {

// CLOCK_MONOTONIC now [ns] (since an arbitrary start, e.g. boot).
std::int64_t MonotonicNs();

// Sleeps until the absolute time deadline_ns [ns] of clock_id (clock_nanosleep with
// TIMER_ABSTIME). Returns 0 when the deadline is reached; returns at once with 0 when it has
// already passed (negative deadlines included). A signal (EINTR) resumes the sleep towards
// the same deadline; any other failure (EINVAL for a bad clock id, ENOTSUP, ...) is returned
// as its errno value without sleeping further.
[[nodiscard]] int SleepUntilNs(std::int64_t deadline_ns, clockid_t clock_id = CLOCK_MONOTONIC);

}  // namespace mrd::common
