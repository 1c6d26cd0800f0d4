#pragma once
// The fault-reset rule both fieldbus devices drive (a Modbus fault_reset point, a CAN
// fault_reset bit): for a driver that latches its faults until reset, one write carries 1 and
// the following ones 0 — a rising edge — while the driver reports a fault and the firmware has
// no active cause other than the driver's, at most once per interval. Never in a shutdown
// write (the caller does not ask then). No allocation, no throw: the real-time path.

#include <cstdint>

#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {

class FaultResetRule {
 public:
  // True when this write carries the edge (1). driver_fault: the driver's latest status reports
  // a fault; causes: the firmware's active watchdog causes (bit i = cause i); now_ns: the
  // device's time (granted time in lockstep); interval_ns: the least time between two edges.
  bool Edge(bool driver_fault, unsigned causes, std::int64_t now_ns, std::int64_t interval_ns) {
    // The driver's own fault shows as these causes; any other keeps the reset back.
    constexpr unsigned kDriverSide = (1U << static_cast<unsigned>(FaultCause::kDriverFault)) |
                                     (1U << static_cast<unsigned>(FaultCause::kFaultLine));
    if (!driver_fault || (causes & ~kDriverSide) != 0) return false;
    if (fired_ && now_ns - last_ns_ < interval_ns) return false;
    fired_ = true;
    last_ns_ = now_ns;
    return true;
  }

 private:
  bool fired_ = false;        // an edge was sent
  std::int64_t last_ns_ = 0;  // when the last edge was sent [ns]
};

}  // namespace mrd::firmware
