#include "mrd/firmware/configure_status.hpp"

namespace mrd::firmware {

const char* ConfigureFaultName(ConfigureFault fault) {
  switch (fault) {
    case ConfigureFault::kNone:
      return "ok";
    case ConfigureFault::kTable:
      return "the table does not configure a controller";
    case ConfigureFault::kEMax:
      return "E_max outside the table's range";
    case ConfigureFault::kEnvelope:
      return "envelope margin negative or not finite";
    case ConfigureFault::kLimits:
      return "plausibility limit negative or not a number";
    case ConfigureFault::kSafeVoltage:
      return "safe voltage outside the table's range";
    case ConfigureFault::kLaw:
      return "control law setting out of range";
    case ConfigureFault::kClippedGains:
      return "clipped-optimal law without valid one-damper gains";
    case ConfigureFault::kWatchdog:
      return "watchdog setting out of range";
    case ConfigureFault::kCutoff:
      return "velocity cut-off not a positive frequency";
  }
  return "unknown";
}

}  // namespace mrd::firmware
