#include "mrd/firmware/io/grant_clock.hpp"

#include "mrd/common/clock.hpp"

namespace mrd::firmware {
namespace {

// Wall time (CLOCK_MONOTONIC) [ns]: how long the harness has been silent.
std::int64_t WallNs() { return common::MonotonicNs(); }

}  // namespace

void GrantClock::SleepUntil(std::int64_t t_ns) {
  std::int64_t last_grant_wall = WallNs();
  while (now_ < t_ns && !halted_) {
    if (stop_ != nullptr && stop_->load(std::memory_order_relaxed)) {
      halted_ = true;
      return;
    }
    const std::int64_t waited = WallNs() - last_grant_wall;
    if (waited >= give_up_ns_) {
      halted_ = gave_up_ = true;
      return;
    }
    const std::int64_t left = give_up_ns_ - waited;
    std::int64_t granted = 0;
    if (!source_.WaitGrant(left < kSliceNs ? left : kSliceNs, &granted)) continue;
    ++grants_;
    last_grant_wall = WallNs();
    if (granted > now_) now_ = granted;  // grants never move time backwards
  }
}

}  // namespace mrd::firmware
