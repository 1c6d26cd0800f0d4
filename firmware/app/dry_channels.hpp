#pragma once
// --dry-run with several damper channels ([channels] count > 1): each channel on a simulated
// damper of its own (channel i: the stroke 8 i % smaller, the body i/8 of a period later than
// the [simulation] excitation), its controller on
// its table (one model per distinct table, shared), the config's fault policy and body law, on
// one loop: lockstep (simulated time) or CLOCK_MONOTONIC in the calling thread (no SCHED_FIFO).
// The per-period log records channel 0; the runtime parameters are not applied (the config
// refuses [ctl] with several channels).

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "mrd/common/table.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/sim/spencer_damper.hpp"
#include "summary_json.hpp"

namespace mrd::firmware {

struct DryChannelsRun {
  const platform::FirmwareConfig& cfg;
  const mrd::CoefficientTable& run_table;  // channels without a table of their own
  const char* run_table_name;
  const mrd::SpencerParams& damper;
  std::int64_t duration_ns;
  bool lockstep;
  PeriodObserver* observer;  // channel 0's per-period records; nullptr: none
};

// Runs the channels until duration or stop; channel 0's telemetry in *first, every channel's
// in *channels (table names point into cfg or run_table_name). "" or why a channel's table or
// the body law was refused (exit 2).
std::string RunDryChannels(const DryChannelsRun& run, const std::atomic<bool>& stop,
                           Telemetry* first, std::vector<SummaryInfo::Channel>* channels);

}  // namespace mrd::firmware
