#include "summary_json.hpp"

#include <iterator>
#include <nlohmann/json.hpp>

#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {
namespace {

using Json = nlohmann::ordered_json;

// One value on one line, objects as {"k": v, ...}; strings escaped (invalid UTF-8 replaced),
// non-finite numbers as null.
std::string Inline(const Json& v) {
  if (!v.is_object()) return v.dump(-1, ' ', false, Json::error_handler_t::replace);
  std::string out = "{";
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (it != v.begin()) out += ", ";
    out += Json(it.key()).dump(-1, ' ', false, Json::error_handler_t::replace) + ": " +
           Inline(it.value());
  }
  return out + "}";
}

// The active causes' names, "+"-joined ("" when none).
std::string CauseNames(std::uint32_t causes) {
  std::string out;
  for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
    if ((causes & (1U << i)) == 0) continue;
    if (!out.empty()) out.append("+");  // appends: GCC 12's false -Wrestrict on string sums
    out.append(FaultCauseName(static_cast<FaultCause>(i)));
  }
  return out;
}

// One channel's counters, safe state and its reason at the end of the run.
Json ChannelJson(std::size_t index, const SummaryInfo::Channel& c) {
  const TelemetrySnapshot& s = c.stats;
  Json trips = Json::object();
  for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
    trips[FaultCauseName(static_cast<FaultCause>(i))] = s.watchdog.trips[i];
  }
  Json j = {{"channel", index},
            {"table", c.table},
            {"ticks", s.ticks},
            {"read_faults", s.read_faults},
            {"write_faults", s.write_faults},
            {"unreachable_demands", s.unreachable},
            {"passive_demands", s.passive_demands},
            {"model_resets", s.model_resets},
            {"safe_periods", s.watchdog.safe_periods},
            {"safe_entries", s.watchdog.entries},
            {"trips", trips},
            {"last_command_v", s.last_command_v},
            {"final_safe_state", s.safe},
            {"last_causes", CauseNames(s.active_causes)}};
  if (c.has_device) {  // the channel's own bus device (several channels on [can])
    const DeviceCounters& d = c.device.counters;
    j["device"] = {{"name", c.device.name},
                   {"rx_ok", d.rx_ok},
                   {"rx_rejected", d.rx_rejected},
                   {"tx_ok", d.tx_ok},
                   {"tx_failed", d.tx_failed},
                   {"last_error", IoErrorName(d.last_error)},
                   {"read_fault_periods", c.device.faults.read_periods()},
                   {"write_fault_periods", c.device.faults.write_periods()}};
  }
  return j;
}

}  // namespace

std::string SummaryJson(const TelemetrySnapshot& s, const SummaryInfo& info) {
  try {
    Json j;
    j["mode"] = info.mode;
    j["table"] = info.table;
    if (*info.plant != '\0') {
      j["plant"] = info.plant;
    } else {
      j["plant"] = nullptr;
    }
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
    j["passive_demands"] = s.passive_demands;
    j["non_monotone_periods"] = s.non_monotone;
    j["model_resets"] = s.model_resets;
    j["envelope_excursions"] = s.envelope_excursions;
    j["force_excursions"] = s.force_excursions;
    j["safe_periods"] = s.watchdog.safe_periods;
    j["safe_entries"] = s.watchdog.entries;
    Json wd = Json::object();
    for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
      wd[FaultCauseName(static_cast<FaultCause>(i))] = {{"trips", s.watchdog.trips[i]},
                                                        {"periods", s.watchdog.active_periods[i]}};
    }
    j["watchdog"] = wd;
    j["last_command_v"] = s.last_command_v;
    j["model_force_n"] = s.model_force_n;
    j["force_demand_n"] = s.force_demand_n;
    j["rms_model_error_n"] = info.rms_model_error_n;  // NaN/inf (diverging plant) -> null
    j["rms_tracking_error_n"] = info.rms_tracking_error_n;
    Json devices = Json::object();
    for (const SummaryInfo::Device& d : info.devices) {
      const DeviceCounters& c = d.counters;
      Json errors = Json::object();
      for (std::size_t i = 0; i < kNumIoErrors; ++i) {
        errors[IoErrorName(static_cast<IoError>(i))] = c.errors[i];
      }
      // The loop's view: periods whose read (write) of this device faulted, per reason.
      Json read = Json::object(), write = Json::object();
      for (std::size_t i = 0; i < kNumIoErrors; ++i) {
        read[IoErrorName(static_cast<IoError>(i))] = d.faults.read[i];
        write[IoErrorName(static_cast<IoError>(i))] = d.faults.write[i];
      }
      devices[d.name] = {{"rx_ok", c.rx_ok},
                         {"rx_rejected", c.rx_rejected},
                         {"tx_ok", c.tx_ok},
                         {"tx_failed", c.tx_failed},
                         {"reconnects", c.reconnects},
                         {"last_error", IoErrorName(c.last_error)},
                         {"errors", errors},
                         {"faulted_periods", {{"read", read}, {"write", write}}},
                         {"last_period_fault",
                          {{"read", IoErrorName(d.faults.last_read)},
                           {"write", IoErrorName(d.faults.last_write)}}}};
    }
    j["devices"] = devices;
    j["final_safe_state"] = s.safe;
    j["parameters"] = {{"changes", info.param_changes}, {"reloads", info.reloads}};
    j["clock"] = {
        {"mode", info.clock}, {"grants", info.grants}, {"missed_grants", info.missed_grants}};
    if (info.log != nullptr) {
      const platform::PeriodLogStats& l = *info.log;
      j["log"] = {{"path", info.log_path}, {"records_written", l.written}, {"dropped", l.dropped},
                  {"lost", l.lost},        {"blocks", l.blocks},           {"bytes", l.bytes},
                  {"files", l.files},      {"stopped", l.failed},          {"error", l.error}};
    } else {
      j["log"] = nullptr;
    }
    if (!info.channels.empty()) {
      j["fault_policy"] = info.fault_policy;
      Json channels = Json::array();
      for (std::size_t i = 0; i < info.channels.size(); ++i) {
        channels.push_back(ChannelJson(i, info.channels[i]));
      }
      j["channels"] = channels;
    }
    // One key per line (the layout scripts and tests read), nested objects inline.
    std::string out = "{\n";
    for (auto it = j.begin(); it != j.end(); ++it) {
      out += "  " + Inline(Json(it.key())) + ": " + Inline(it.value()) +
             (std::next(it) == j.end() ? "\n" : ",\n");
    }
    return out + "}\n";
  } catch (...) {
    return "";
  }
}

}  // namespace mrd::firmware
