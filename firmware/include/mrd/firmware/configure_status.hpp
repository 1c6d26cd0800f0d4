#pragma once
// Why Controller::Configure refused a table and configuration: one reason per check, in the
// order Configure makes them (the first failing check wins).

#include <cstdint>

#include "mrd/common/result.hpp"

namespace mrd::firmware {

enum class ConfigureFault : std::uint8_t {
  kNone = 0,
  kTable,         // the table does not bind: Validate fails, a channel the firmware does not
                  // provide, a number overflowing Real, or a model the inverter cannot invert
  kEMax,          // E_max not in (table E_min, table E_max] or not finite
  kEnvelope,      // envelope margin negative or not finite
  kLimits,        // velocity or displacement plausibility limit negative or NaN
  kSafeVoltage,   // safe voltage not finite or outside the table's [E_min, E_max]
  kLaw,           // the law's settings (gains, constant voltage, ...) out of range
  kClippedGains,  // clipped-optimal law without loaded, valid gains
  kWatchdog,      // sensor max age <= 0 or recover_periods 0
  kCutoff,        // velocity differentiator cut-off not finite or <= 0 [Hz]
};

// Short, static description of a fault, e.g. "E_max outside the table's range" (never
// allocates; "unknown" for a value outside the enum).
const char* ConfigureFaultName(ConfigureFault fault);

// What Configure returns: the reason, and the error code (kOk; the table's own error for
// kTable; kOutOfRange otherwise). Converts to the code for callers that only test success.
struct ConfigureStatus {
  ConfigureFault fault = ConfigureFault::kNone;
  Error error = Error::kOk;

  bool ok() const { return fault == ConfigureFault::kNone; }
  operator Error() const { return error; }  // NOLINT(google-explicit-constructor)
};

}  // namespace mrd::firmware
