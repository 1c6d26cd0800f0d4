#pragma once
// Import of foreign CSV data (bench rigs, published data sets) into the toolkit's data-file
// form: columns t,x,v,E,f (+ any other mapped names), uniform time from 0, a chosen rate.
//
// Known quirks are repaired and counted in the report, never silently:
//   - quoted header names ("t")                  -> unquoted
//   - a trailing separator on the header line    -> the empty last field of every line is
//                                                   dropped (a value there is an error)
//   - sparse columns (empty in some rows, e.g. a rate filled only in the first row)
//                                                -> dropped when unmapped (an error when mapped)
//   - an incomplete last line (fewer fields, a field that is not a number, or no trailing
//     separator where every other line has one)  -> dropped, reported with its line number
//   - a t column printed with few digits         -> rate fitted over all rows by least squares;
//     deviations from that grid up to half the printed resolution (10^-(most decimals seen
//     among values of the same decade), capped at a quarter period) + max_jitter periods pass
// Anything else malformed throws InputError naming file, line and reason: unknown column in
// the map, a mapped value that is empty, not a number or non-finite, a wrong field count
// before the last line, a blank line before the last line, non-increasing time, time off the
// uniform grid by more than rounding + max_jitter periods, a stated rate that disagrees with
// the time column by more than 0.1 %.

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace mrd::host {

struct ImportOptions {
  std::string in_path;
  // Output name -> input column, in the order given (e.g. {"x", "D"}). Must map t, x, E, f
  // and v (unless derive_velocity); other output names are allowed and follow t,x,v,E,f.
  std::vector<std::pair<std::string, std::string>> map;
  // Output name -> factor applied after mapping (t included; on x before differentiation;
  // on v also when derived).
  std::vector<std::pair<std::string, double>> scale;
  double out_rate_hz = 1000.0;   // output sampling rate [Hz]
  bool derive_velocity = false;  // v from x by a filtered differentiator
  // -6 dB cut-off of that differentiator [Hz]; the default matches the 100 Hz anti-alias
  // filter of the NEES-2012-1158 acquisition, above which differentiation mostly amplifies
  // noise.
  double velocity_cutoff_hz = 100.0;
  double max_jitter = 0.01;  // allowed time deviation beyond rounding [periods]
  char separator = ',';
  std::string rate_column = "fs";  // sparse column stating the rate ("" = none)
};

// Checks ranges (rates, cut-off, jitter, names); throws InputError("", 0, reason).
void ValidateImportOptions(const ImportOptions& options);

struct SparseColumn {
  std::string name;
  std::size_t filled = 0;      // rows holding a value
  std::size_t first_line = 0;  // file line of the first value (0 when none)
  std::string first_value;     // that value, as written
};

struct ImportReport {
  std::string in_path;
  std::size_t data_lines = 0;  // lines after the header
  std::size_t rows_read = 0;   // data rows kept
  std::size_t rows_written = 0;
  std::size_t quoted_names = 0;         // header names that were quoted
  bool bom = false;                     // a UTF-8 byte-order mark was removed
  std::size_t trailing_separators = 0;  // lines (header included) ending in a separator
  std::vector<SparseColumn> sparse_dropped;
  std::vector<std::string> ignored;              // complete but unmapped columns
  std::optional<std::size_t> dropped_last_line;  // file line of the incomplete last row
  std::string dropped_last_reason;
  double in_rate_hz = 0.0;               // fitted from the time column
  double t_start_s = 0.0;                // first input time (output time 0)
  double t_resolution_s = 0.0;           // coarsest printed resolution of t
  double t_max_deviation_s = 0.0;        // largest |t - uniform fit|
  std::optional<double> stated_rate_hz;  // from rate_column, when present
  double out_rate_hz = 0.0;
  std::string anti_alias;            // filter description
  std::string velocity;              // how v was obtained
  std::vector<std::string> names;    // output columns
  std::vector<std::string> mapping;  // one "out <- in" entry per output column
};

struct ImportResult {
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;  // columns[0] is t, n / out_rate_hz
  ImportReport report;
};

// Reads, repairs, validates, maps, scales, derives and resamples; writes nothing.
// Throws InputError (file, line, reason) for bad input.
ImportResult Import(const ImportOptions& options);

// Multi-line human-readable report.
std::string FormatImportReport(const ImportReport& report);

// "t=t,x=D" -> {{"t","t"},{"x","D"}}; throws InputError("", 0, ...) naming the flag on a
// malformed pair, an empty or duplicate name.
std::vector<std::pair<std::string, std::string>> ParseImportMap(const std::string& spec);
// "f=1,x=0.01" -> {{"f",1},{"x",0.01}}; also rejects non-numeric, zero or non-finite factors.
std::vector<std::pair<std::string, double>> ParseImportScale(const std::string& spec);

}  // namespace mrd::host
