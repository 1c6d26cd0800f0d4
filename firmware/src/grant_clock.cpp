#include "mrd/firmware/grant_clock.hpp"

namespace mrd::firmware {

void GrantClock::SleepUntil(std::int64_t t_ns) {
  while (now_ < t_ns) {
    std::int64_t granted = 0;
    const bool first = grants_ == 0 && missed_ == 0;
    if (!source_.WaitGrant(first ? first_timeout_ns_ : timeout_ns_, &granted)) {
      ++missed_;
      return;  // a fault, not a hang: the period runs (safe) at the last granted time
    }
    ++grants_;
    if (granted > now_) now_ = granted;  // grants never move time backwards
  }
}

}  // namespace mrd::firmware
