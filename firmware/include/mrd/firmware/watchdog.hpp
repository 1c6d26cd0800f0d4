#pragma once
// Watchdog: decides each period whether the driver must be in the safe state.
//
//   safe(k) = any cause active at k, or fewer than recover_periods clean periods since the
//             last active cause.
//
// Causes: stale sensor data (age > max_age), a non-finite input or model force (the model
// diverged the period before and was reset), a sensor-source fault that names no bus
// (simulated sources), a driver fault (last write failed), the external fault line, an
// implausible sensor value (velocity or displacement beyond its configured limit), and a
// fault per bus (CAN, Modbus, GPIO: the device reported why in its counters), and another
// channel's fault under FaultPolicy::kAll (loop.hpp). Counters per
// cause: periods in which it was active and trips (inactive -> active transitions).

#include <array>
#include <cstdint>
#include <iterator>

#include "mrd/common/fault_causes.hpp"

namespace mrd::firmware {

// The causes and their names from one list (mrd/common/fault_causes.hpp), in bit order:
// kStaleSensor = 0, kNonFinite, kBusFault, kDriverFault, kFaultLine, kImplausible, kCanBus,
// kModbusBus, kGpioBus, kOtherChannel (another damper channel faulted: loop.hpp FaultPolicy).
enum class FaultCause : std::uint8_t {
#define MRD_FAULT_CAUSE_ENUMERATOR(enumerator, name) enumerator,
  MRD_FAULT_CAUSES(MRD_FAULT_CAUSE_ENUMERATOR)
#undef MRD_FAULT_CAUSE_ENUMERATOR
};
inline constexpr std::size_t kNumFaultCauses = std::size(kFaultCauseNames);
static_assert(static_cast<std::size_t>(FaultCause::kOtherChannel) + 1 == kNumFaultCauses,
              "one name per cause");

// Static name ("stale_sensor", "non_finite", "bus_fault", "driver_fault", "fault_line",
// "implausible", "can_bus", "modbus_bus", "gpio_bus", "other_channel"; "unknown" for a value past
// the list).
const char* FaultCauseName(FaultCause cause);

struct WatchdogConfig {
  std::int64_t max_age_ns = 5'000'000;  // sensor data older than this is stale [ns], > 0
  std::uint32_t recover_periods = 1;    // clean periods before leaving the safe state, >= 1
};

struct WatchdogCounters {
  std::array<std::uint64_t, kNumFaultCauses> active_periods{};
  std::array<std::uint64_t, kNumFaultCauses> trips{};
  std::uint64_t safe_periods = 0;  // periods commanded in the safe state
  std::uint64_t entries = 0;       // normal -> safe transitions
};

class Watchdog {
 public:
  void Configure(const WatchdogConfig& config) { config_ = config; }
  // Forgets the history and counters; starts in the safe state until inputs are clean.
  void Reset();
  // One period: a bit set per active cause (bit i = FaultCause i). Returns true when the
  // safe state must be commanded this period. Real-time safe.
  bool Update(std::uint32_t active_causes);
  static constexpr std::uint32_t Bit(FaultCause c) { return 1U << static_cast<unsigned>(c); }

  bool safe() const { return safe_; }
  std::uint32_t active() const { return active_; }
  const WatchdogCounters& counters() const { return counters_; }
  const WatchdogConfig& config() const { return config_; }

 private:
  WatchdogConfig config_;
  WatchdogCounters counters_;
  std::uint32_t active_ = 0;
  std::uint32_t clean_periods_ = 0;
  bool safe_ = true;
};

}  // namespace mrd::firmware
