#include "mrd/common/clock.hpp"

#include <cerrno>

namespace mrd::common {

std::int64_t MonotonicNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

int SleepUntilNs(std::int64_t deadline_ns, clockid_t clock_id) {
  if (deadline_ns < 0) deadline_ns = 0;  // long past: timespec cannot hold a negative time
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(deadline_ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(deadline_ns % 1'000'000'000);
  while (true) {
    // clock_nanosleep returns the error number (it does not set errno).
    const int r = clock_nanosleep(clock_id, TIMER_ABSTIME, &ts, nullptr);
    if (r != EINTR) return r;
  }
}

}  // namespace mrd::common
