#pragma once
// The dry-run summary of mrd-firmware as one JSON object (nlohmann-json: strings escaped,
// non-finite numbers written as null). This file alone is compiled with exceptions.

#include <cstdint>
#include <string>
#include <vector>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/platform/period_log.hpp"
#include "mrd/firmware/telemetry.hpp"

namespace mrd::firmware {

struct SummaryInfo {
  const char* mode = "";   // "lockstep" | "realtime" | "bus"
  const char* table = "";  // table file path or "compiled-in"
  const char* plant = "";  // dry run: the simulated damper (--plant FILE); "": a bus run (null)
  const char* law = "";
  double seconds = 0.0;  // dry-run duration, or ticks x period on the buses [s]
  double period_us = 0.0;
  bool sched_fifo = false;
  bool memory_locked = false;
  double rms_model_error_n = 0.0;
  double rms_tracking_error_n = 0.0;
  struct Device {
    const char* name;
    DeviceCounters counters;
    DeviceFaults faults;  // the loop's faulted periods of this device, per reason
  };
  std::vector<Device> devices;
  const char* clock = "monotonic";  // bus mode: "monotonic" | "grant" (lockstep)
  std::uint64_t grants = 0;         // lockstep: time grants received
  std::uint64_t param_changes = 0;  // runtime parameter changes applied (mrd-firmware ctl set)
  std::uint64_t reloads = 0;        // reloads applied (SIGHUP)
  const platform::PeriodLogStats* log = nullptr;  // the per-period log; nullptr: none ("log": null)
  const char* log_path = "";
  // Several channels ([channels] count > 1): each one's table and counters, in channel order
  // (the "channels" array); empty: one channel, no "channels" key (the layout unchanged).
  struct Channel {
    const char* table;
    TelemetrySnapshot stats;
    bool has_device = false;  // a bus run: the channel's own field device (its "device")
    Device device{};
  };
  std::vector<Channel> channels;
  const char* fault_policy = "all";
  std::uint64_t missed_grants = 0;  // lockstep: 1 when no grant came within grant_timeout_ms
                                    // (stopped)  // bus mode: per field device (empty in a dry run)
};

// Pretty-printed JSON text with a final newline; "" if it cannot be built (no memory).
std::string SummaryJson(const TelemetrySnapshot& s, const SummaryInfo& info);

}  // namespace mrd::firmware
