#pragma once
// The run's summary (JSON; keys in docs/hil_summary.md) and its files in --out: summary.json,
// trace.csv, firmware.toml (the generated config) and gnuplot plots (tracking.png,
// command.png, and ride.png for a quarter car; skipped with a warning without gnuplot).

#include <nlohmann/json.hpp>
#include <string>

#include "mrd/common/time_window.hpp"
#include "mrd/hil/run/run.hpp"

namespace mrd::hil {

nlohmann::json SummaryJson(const Scenario& s, const RunResult& r);
// A short text summary.
std::string SummaryText(const Scenario& s, const RunResult& r);
// Runs gnuplot on script (its stderr to log); 0 on success, -1 without gnuplot.
int Gnuplot(const std::string& script, const std::string& log);
// Gnuplot's return rc (non-zero) as the warning of a command whose plots go to dir/ (log
// dir/gnuplot.log): "gnuplot not found ...: plots skipped" or "gnuplot failed ...".
std::string GnuplotWarning(int rc, const std::string& dir);
// Writes the files; false with *error. Plot failures are warnings (*warning).
// Time plots: window (nullptr: the first 5 s) sample by sample, the whole run's envelope below.
bool WriteOutputs(const std::string& dir, const nlohmann::json& summary, const RunResult& r,
                  const TimeWindow* window, std::string* error, std::string* warning);

}  // namespace mrd::hil
