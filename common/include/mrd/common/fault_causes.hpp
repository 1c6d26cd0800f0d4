#pragma once
// The firmware watchdog's fault causes in bit order (cause i is bit i of the causes word the
// firmware reports in its status, telemetry and period log), each as its enumerator
// (firmware::FaultCause, firmware/include/mrd/firmware/watchdog.hpp) and its name (status,
// logs, the host's plots). One list for both: a cause added here is named everywhere.
//
//   MRD_FAULT_CAUSES(X) expands X(enumerator, "name") once per cause, in bit order.

#include <cstddef>
#include <iterator>

#define MRD_FAULT_CAUSES(X)       \
  X(kStaleSensor, "stale_sensor") \
  X(kNonFinite, "non_finite")     \
  X(kBusFault, "bus_fault")       \
  X(kDriverFault, "driver_fault") \
  X(kFaultLine, "fault_line")     \
  X(kImplausible, "implausible")  \
  X(kCanBus, "can_bus")           \
  X(kModbusBus, "modbus_bus")     \
  X(kGpioBus, "gpio_bus")         \
  X(kOtherChannel, "other_channel")

namespace mrd {

// The causes' names, index = bit.
#define MRD_FAULT_CAUSE_NAME(enumerator, name) name,
inline constexpr const char* kFaultCauseNames[] = {MRD_FAULT_CAUSES(MRD_FAULT_CAUSE_NAME)};
#undef MRD_FAULT_CAUSE_NAME
static_assert(std::size(kFaultCauseNames) <= 32, "each cause is a bit of a 32-bit word");

}  // namespace mrd
