#pragma once
// `mrd log`: reads the firmware's per-period log (common/runlog, docs/logging.md) and
// describes, exports or plots it. Bad input (not a log, another version, a truncated or
// corrupt header, a corrupt block, an unknown field) throws InputError (exit 2); a file cut
// inside its last block (power cut, kill -9) is read up to its last whole block with a note.

#include <functional>
#include <string>
#include <vector>

#include "mrd/common/time_window.hpp"
#include "mrd/runlog/runlog.hpp"

namespace mrd::host {

// Reads path. Throws InputError for what DecodeLog refuses and for a corrupt block unless
// allow_corrupt (then the log holds the blocks before it, see Log::damage).
runlog::Log LoadRunLog(const std::string& path, bool allow_corrupt = false);

// The `mrd log info` text: version, source, period, fields with types and units, records,
// blocks, time span, dropped records, damage found.
std::string RunLogInfo(const runlog::Log& log, const std::string& path);
// A note on the damage ("" when none), e.g. "FILE: truncated: ...".
std::string RunLogDamageNote(const runlog::Log& log, const std::string& path);

// Indices of the named fields in the header, in the order given (every field when fields is
// empty). Throws InputError for an unknown name (listing the fields) or a name given twice.
std::vector<std::size_t> RunLogColumns(const runlog::Header& header,
                                       const std::vector<std::string>& fields);

// CSV text: header row of the field names, one row per record (integers exact, floats
// shortest round-trip, non-finite as nan/inf). fields empty: every field; an unknown name
// throws InputError listing the fields.
std::string RunLogCsv(const runlog::Log& log, const std::vector<std::string>& fields);

// DIR/<stem>_time.png: force (model, demand, measured), voltage (command, law's E) and state
// (safe, each watchdog cause) over a window of the log (window, or the first 5 s; time from
// the first record [s]), sample by sample, the safe state shaded; below, an overview of the
// whole log (the forces' envelopes) with the window marked. Returns the file written. Needs
// gnuplot. progress: one line per step (may be empty).
std::string PlotRunLog(const runlog::Log& log, const std::string& path, const std::string& out_dir,
                       const TimeWindow* window,
                       const std::function<void(const std::string&)>& progress);

}  // namespace mrd::host
