#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {

const char* FaultCauseName(FaultCause cause) {
  switch (cause) {
    case FaultCause::kStaleSensor:
      return "stale_sensor";
    case FaultCause::kNonFinite:
      return "non_finite";
    case FaultCause::kBusFault:
      return "bus_fault";
    case FaultCause::kDriverFault:
      return "driver_fault";
    case FaultCause::kFaultLine:
      return "fault_line";
    case FaultCause::kImplausible:
      return "implausible";
    case FaultCause::kCanBus:
      return "can_bus";
    case FaultCause::kModbusBus:
      return "modbus_bus";
    case FaultCause::kGpioBus:
      return "gpio_bus";
  }
  return "unknown";
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
