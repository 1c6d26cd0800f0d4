#include "mrd/firmware/grant_clock.hpp"

#include <ctime>

namespace mrd::firmware {
namespace {

std::int64_t WallNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

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
