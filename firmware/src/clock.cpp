#include "mrd/common/clock.hpp"

#include "mrd/firmware/io.hpp"

namespace mrd::firmware {

// The Clock interface over mrd/common/clock.hpp (no copy of the clock itself).
std::int64_t MonotonicClock::Now() { return common::MonotonicNs(); }

void MonotonicClock::SleepUntil(std::int64_t t_ns) {
  // Signals resume the sleep; another failure (never with CLOCK_MONOTONIC) returns at once,
  // as before: the loop then sees the deadline missed (an overrun), never hangs.
  (void)common::SleepUntilNs(t_ns);
}

}  // namespace mrd::firmware
