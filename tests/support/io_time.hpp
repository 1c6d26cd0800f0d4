#pragma once
// The period's time (firmware IoTime) for tests that call a device or FieldbusIo directly:
// CLOCK_MONOTONIC read at the call, on both clocks (a loop on CLOCK_MONOTONIC hands the same).

#include "mrd/common/clock.hpp"
#include "mrd/firmware/io.hpp"

namespace mrd::test {

inline firmware::IoTime NowIo() {
  const std::int64_t t = common::MonotonicNs();
  return firmware::IoTime{t, t};
}

}  // namespace mrd::test
