#include "summary_json.hpp"

#include <nlohmann/json.hpp>

#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {

std::string SummaryJson(const TelemetrySnapshot& s, const SummaryInfo& info) {
  try {
    nlohmann::ordered_json j;
    j["mode"] = info.mode;
    j["table"] = info.table;
    j["law"] = info.law;
    j["seconds"] = info.seconds;
    j["period_us"] = info.period_us;
    j["sched_fifo"] = info.sched_fifo;
    j["memory_locked"] = info.memory_locked;
    j["ticks"] = s.ticks;
    j["overruns"] = s.overruns;
    j["missed_periods"] = s.missed_periods;
    j["worst_latency_us"] = static_cast<double>(s.worst_latency_ns) / 1e3;
    j["worst_exec_us"] = static_cast<double>(s.worst_exec_ns) / 1e3;
    j["read_faults"] = s.read_faults;
    j["write_faults"] = s.write_faults;
    j["unreachable_demands"] = s.unreachable;
    j["model_resets"] = s.model_resets;
    j["safe_periods"] = s.watchdog.safe_periods;
    j["safe_entries"] = s.watchdog.entries;
    nlohmann::ordered_json wd = nlohmann::ordered_json::object();
    for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
      wd[FaultCauseName(static_cast<FaultCause>(i))] = {{"trips", s.watchdog.trips[i]},
                                                        {"periods", s.watchdog.active_periods[i]}};
    }
    j["watchdog"] = wd;
    j["last_command_v"] = s.last_command_v;
    j["model_force_n"] = s.model_force_n;
    j["rms_model_error_n"] = info.rms_model_error_n;  // NaN/inf (diverging plant) -> null
    j["rms_tracking_error_n"] = info.rms_tracking_error_n;
    j["final_safe_state"] = s.safe;
    // Invalid UTF-8 in the table path is replaced, never emitted raw.
    return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
  } catch (...) {
    return "";
  }
}

}  // namespace mrd::firmware
