#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {

const char* FaultCauseName(FaultCause cause) {
  const auto i = static_cast<std::size_t>(cause);
  return i < kNumFaultCauses ? kFaultCauseNames[i] : "unknown";
}

void Watchdog::Reset() {
  counters_ = {};
  active_ = 0;
  clean_periods_ = 0;
  safe_ = true;
}

bool Watchdog::Update(std::uint32_t active_causes) {
  for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
    const std::uint32_t bit = 1U << i;
    if ((active_causes & bit) != 0) {
      ++counters_.active_periods[i];
      if ((active_ & bit) == 0) ++counters_.trips[i];
    }
  }
  active_ = active_causes;
  const bool was_safe = safe_;
  if (active_causes != 0) {
    clean_periods_ = 0;
    safe_ = true;
  } else {
    if (clean_periods_ < config_.recover_periods) ++clean_periods_;
    safe_ = clean_periods_ < config_.recover_periods;
  }
  if (safe_ && !was_safe) ++counters_.entries;
  if (safe_) ++counters_.safe_periods;
  return safe_;
}

}  // namespace mrd::firmware
