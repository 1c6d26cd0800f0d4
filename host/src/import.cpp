#include "mrd/host/import.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "csv_tokenizer.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/resample.hpp"

namespace mrd::host {
namespace {

// Output columns that every toolkit data file has, in header order.
const std::vector<std::string> kToolkitNames{"t", "x", "v", "E", "f"};

using csv::Line;
using csv::SplitFields;
using csv::Trim;

bool IsValidName(std::string_view s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) {
    return false;
  }
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

// Parses a whole field as a double (a leading '+' allowed). False when it is empty, not a
// number, or has trailing characters; *value may then be anything.
bool ParseNumber(std::string_view f, double* value) {
  if (!f.empty() && f.front() == '+') f.remove_prefix(1);
  if (f.empty()) return false;
  const char* end = f.data() + f.size();
  const auto res = std::from_chars(f.data(), end, *value);
  if (res.ec == std::errc::result_out_of_range) {
    *value = HUGE_VAL;  // reported as non-finite
    return res.ptr == end;
  }
  return res.ec == std::errc() && res.ptr == end;
}

// Decimals of a number as printed: digits after the point minus the exponent ("19.9997" -> 4,
// "3.328e-4" -> 7, "0" -> 0; negative for "5e3").
int CountDecimals(std::string_view f) {
  int exponent = 0;
  const std::size_t e = f.find_first_of("eE");
  if (e != std::string_view::npos) {
    std::string_view ex = f.substr(e + 1);
    if (!ex.empty() && ex.front() == '+') ex.remove_prefix(1);
    std::from_chars(ex.data(), ex.data() + ex.size(), exponent);
    f = f.substr(0, e);
  }
  const std::size_t dot = f.find('.');
  const int after = dot == std::string_view::npos ? 0 : static_cast<int>(f.size() - dot - 1);
  return after - exponent;
}

template <typename T>
const T* FindByName(const std::vector<std::pair<std::string, T>>& pairs, const std::string& name) {
  for (const auto& [k, v] : pairs) {
    if (k == name) return &v;
  }
  return nullptr;
}

std::vector<std::pair<std::string, std::string>> SplitPairs(const std::string& spec,
                                                            const char* flag) {
  std::vector<std::pair<std::string, std::string>> out;
  std::vector<std::string_view> items;
  SplitFields(spec, ',', &items);
  for (std::string_view item : items) {
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos) {
      throw InputError("", 0, fmt::format("{}: '{}' is not NAME=VALUE", flag, item));
    }
    const std::string key(Trim(item.substr(0, eq)));
    const std::string value(Trim(item.substr(eq + 1)));
    if (!IsValidName(key)) {
      throw InputError("", 0, fmt::format("{}: '{}' is not a valid output name", flag, key));
    }
    if (value.empty()) throw InputError("", 0, fmt::format("{}: '{}' has no value", flag, key));
    for (const auto& p : out) {
      if (p.first == key) throw InputError("", 0, fmt::format("{}: '{}' given twice", flag, key));
    }
    out.emplace_back(key, value);
  }
  return out;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> ParseImportMap(const std::string& spec) {
  auto pairs = SplitPairs(spec, "--map");
  for (auto& p : pairs) {  // input column names may be written quoted, as in the header
    if (p.second.size() >= 2 && p.second.front() == '"' && p.second.back() == '"') {
      p.second = p.second.substr(1, p.second.size() - 2);
    }
  }
  return pairs;
}

std::vector<std::pair<std::string, double>> ParseImportScale(const std::string& spec) {
  std::vector<std::pair<std::string, double>> out;
  for (const auto& [name, text] : SplitPairs(spec, "--scale")) {
    double value = 0.0;
    if (!ParseNumber(text, &value) || !std::isfinite(value) || value == 0.0) {
      throw InputError("", 0,
                       fmt::format("--scale {}={}: need a finite, non-zero number", name, text));
    }
    out.emplace_back(name, value);
  }
  return out;
}

void ValidateImportOptions(const ImportOptions& o) {
  if (!(o.out_rate_hz > 0.0) || !std::isfinite(o.out_rate_hz)) {
    throw InputError("", 0,
                     fmt::format("--rate {}: must be a positive number of Hz", o.out_rate_hz));
  }
  if (!(o.velocity_cutoff_hz > 0.0) || !std::isfinite(o.velocity_cutoff_hz)) {
    throw InputError(
        "", 0, fmt::format("--cutoff {}: must be a positive number of Hz", o.velocity_cutoff_hz));
  }
  if (!(o.max_jitter >= 0.0) || !(o.max_jitter < 0.5)) {
    throw InputError("", 0,
                     fmt::format("--max-jitter {}: must be in [0, 0.5) periods", o.max_jitter));
  }
  const auto mapped = [&](const std::string& n) { return FindByName(o.map, n) != nullptr; };
  for (const std::string& n : kToolkitNames) {
    if (n == "v" && o.derive_velocity) {
      if (mapped("v")) {
        throw InputError("", 0,
                         "--map gives v and --derive-velocity derives it: use one (map the "
                         "file's velocity to another name to keep both)");
      }
      continue;
    }
    if (!mapped(n)) {
      throw InputError("", 0,
                       fmt::format("--map lacks '{}' (needs t,x,v,E,f; v may come from "
                                   "--derive-velocity)",
                                   n));
    }
  }
  for (const auto& [name, factor] : o.scale) {
    if (!mapped(name) && !(name == "v" && o.derive_velocity)) {
      throw InputError("", 0, fmt::format("--scale {}: not an output column", name));
    }
    if (!std::isfinite(factor) || factor == 0.0) {
      throw InputError("", 0, fmt::format("--scale {}: need a finite, non-zero factor", name));
    }
  }
  if (o.separator == '"' || o.separator == '\n' || o.separator == '\r' || o.separator == '.' ||
      o.separator == '-' || o.separator == '+' ||
      std::isalnum(static_cast<unsigned char>(o.separator))) {
    throw InputError("", 0, "separator: must not be a quote, digit, letter, sign or point");
  }
}

namespace {

// The input file as the phases of Import see it: the header's column names and the kept rows'
// fields (views into content: never copied or moved once read).
struct InputTable {
  std::string path;
  std::string content;
  std::vector<Line> lines;
  std::vector<std::string> names;  // input columns
  bool trailing = false;           // the header ends with a separator
  std::size_t ncol = 0;
  std::size_t expected = 0;             // fields per line, the trailing one included
  std::vector<bool> mapped;             // [input column]: named by --map
  std::vector<std::string_view> cells;  // kept rows, row-major
  std::vector<std::size_t> row_line;    // file line of each kept row
  std::size_t rows = 0;

  std::string_view cell(std::size_t r, std::size_t c) const { return cells[r * ncol + c]; }
  // Index of the input column in_name; ncol when there is none.
  std::size_t column_of(const std::string& in_name) const {
    const auto it = std::find(names.begin(), names.end(), in_name);
    return it == names.end() ? ncol : static_cast<std::size_t>(it - names.begin());
  }
};

// Phase 1: the file, without a UTF-8 byte-order mark, in lines; the header must not be empty.
void ReadLines(InputTable& in, ImportReport& rep) {
  in.content = csv::ReadFile(in.path);
  if (in.content.starts_with("\xEF\xBB\xBF")) {
    in.content.erase(0, 3);
    rep.bom = true;
  }
  in.lines = csv::SplitLines(in.content, in.path);
  if (in.lines.empty() || Trim(in.lines[0].text).empty()) {
    throw InputError(in.path, 1, "empty file (no header row)");
  }
}

// Phase 2 (header): names, quoted or not, optionally followed by a trailing separator.
void ReadHeader(const ImportOptions& o, InputTable& in, ImportReport& rep) {
  std::vector<std::string_view> fields;
  SplitFields(in.lines[0].text, o.separator, &fields);
  in.trailing = fields.size() > 1 && fields.back().empty();
  if (in.trailing) {
    fields.pop_back();
    ++rep.trailing_separators;
  }
  for (std::size_t c = 0; c < fields.size(); ++c) {
    std::string_view name = fields[c];
    if (!name.empty() && (name.front() == '"' || name.back() == '"')) {
      if (name.size() < 2 || name.front() != '"' || name.back() != '"') {
        throw InputError(in.path, 1, fmt::format("unbalanced quote in column name {}", name));
      }
      name = Trim(name.substr(1, name.size() - 2));
      ++rep.quoted_names;
    }
    if (name.empty()) throw InputError(in.path, 1, fmt::format("column {} has no name", c + 1));
    if (std::find(in.names.begin(), in.names.end(), name) != in.names.end()) {
      throw InputError(in.path, 1, fmt::format("duplicate column '{}'", name));
    }
    in.names.emplace_back(name);
  }
  in.ncol = in.names.size();
  in.expected = in.ncol + (in.trailing ? 1 : 0);
}

// Phase 3 (map): the output names (t,x,v,E,f first, then the others in map order); every
// mapped input column must exist.
std::vector<std::string> MapColumns(const ImportOptions& o, InputTable& in) {
  std::vector<std::string> out_names;
  for (const std::string& n : kToolkitNames) out_names.push_back(n);
  for (const auto& [out, in_name] : o.map) {
    if (std::find(out_names.begin(), out_names.end(), out) == out_names.end()) {
      out_names.push_back(out);
    }
    if (in.column_of(in_name) == in.ncol) {
      throw InputError(in.path, 1,
                       fmt::format("--map {}={}: no column '{}' (columns: {})", out, in_name,
                                   in_name, fmt::join(in.names, ",")));
    }
  }
  in.mapped.assign(in.ncol, false);
  for (const auto& p : o.map) in.mapped[in.column_of(p.second)] = true;
  return out_names;
}

// Why the last line (fields) is incomplete and dropped; empty: it is a complete row.
std::string IncompleteLastLine(const InputTable& in, bool blank, std::size_t nf,
                               const std::vector<std::string_view>& fields) {
  std::string reason;
  if (blank) {
    reason = fmt::format("empty line, 0 of {} fields", in.ncol);
  } else if (in.trailing && nf == in.expected - 1) {
    reason = fmt::format(
        "no trailing separator where every other line has one: the last "
        "field '{}' may be truncated",
        fields.back());
  } else if (nf < in.expected) {
    reason = fmt::format("{} of {} fields", std::min(nf, in.ncol), in.ncol);
  } else if (nf == in.expected) {
    for (std::size_t c = 0; c < in.ncol && reason.empty(); ++c) {
      double value = 0.0;
      if (in.mapped[c] && !ParseNumber(fields[c], &value)) {
        reason = fmt::format("column '{}' is not a complete number: '{}'", in.names[c], fields[c]);
      }
    }
  }
  return reason;
}

// Phase 4 (data lines): the fields of the kept rows; an incomplete last row is dropped, with
// the reason; at least 2 rows.
void ReadRows(const ImportOptions& o, InputTable& in, ImportReport& rep) {
  std::vector<std::string_view> fields;
  rep.data_lines = in.lines.size() - 1;
  for (std::size_t i = 1; i < in.lines.size(); ++i) {
    const Line& line = in.lines[i];
    const bool is_last = i + 1 == in.lines.size();
    const bool blank = Trim(line.text).empty();
    SplitFields(line.text, o.separator, &fields);
    const std::size_t nf = blank ? 0 : fields.size();
    if (is_last) {
      const std::string reason = IncompleteLastLine(in, blank, nf, fields);
      if (!reason.empty()) {
        rep.dropped_last_line = line.number;
        rep.dropped_last_reason = reason;
        break;
      }
    }
    if (blank) throw InputError(in.path, line.number, "blank line");
    if (nf != in.expected) {
      throw InputError(in.path, line.number,
                       fmt::format("expected {} fields{}, found {}", in.expected,
                                   in.trailing ? " (with the trailing separator)" : "", nf));
    }
    if (in.trailing) {
      if (!fields.back().empty()) {
        throw InputError(in.path, line.number,
                         fmt::format("value '{}' after the last named column", fields.back()));
      }
      ++rep.trailing_separators;
    }
    in.cells.insert(in.cells.end(), fields.begin(),
                    fields.begin() + static_cast<std::ptrdiff_t>(in.ncol));
    in.row_line.push_back(line.number);
  }
  in.rows = in.row_line.size();
  rep.rows_read = in.rows;
  if (in.rows < 2) throw InputError(in.path, in.lines.back().number, "fewer than 2 data rows");
}

// Phase 5 (columns): sparse ones dropped (an error when mapped), complete unmapped ones
// ignored. Returns the rate column when it has a value.
std::optional<std::size_t> SortColumns(const ImportOptions& o, const InputTable& in,
                                       ImportReport& rep) {
  std::optional<std::size_t> rate_col;
  for (std::size_t c = 0; c < in.ncol; ++c) {
    std::size_t filled = 0;
    std::size_t first = in.rows;
    std::size_t first_empty = in.rows;
    for (std::size_t r = 0; r < in.rows; ++r) {
      if (in.cell(r, c).empty()) {
        first_empty = std::min(first_empty, r);
      } else {
        ++filled;
        first = std::min(first, r);
      }
    }
    if (in.mapped[c]) {
      if (filled < in.rows) {
        throw InputError(in.path, in.row_line[first_empty],
                         fmt::format("column '{}' (mapped) has no value", in.names[c]));
      }
      continue;
    }
    if (!o.rate_column.empty() && in.names[c] == o.rate_column && filled > 0) rate_col = c;
    if (filled < in.rows) {
      rep.sparse_dropped.push_back({in.names[c], filled, filled > 0 ? in.row_line[first] : 0,
                                    filled > 0 ? std::string(in.cell(first, c)) : std::string()});
    } else {
      rep.ignored.push_back(in.names[c]);
    }
  }
  return rate_col;
}

double ScaleOf(const ImportOptions& o, const std::string& out) {
  const double* s = FindByName(o.scale, out);
  return s ? *s : 1.0;
}

// Input column in (mapped to out) as finite numbers, scaled.
std::vector<double> ReadColumn(const ImportOptions& o, const InputTable& in, const std::string& out,
                               const std::string& in_name) {
  const std::size_t c = in.column_of(in_name);
  const double k = ScaleOf(o, out);
  std::vector<double> values(in.rows);
  for (std::size_t r = 0; r < in.rows; ++r) {
    double v = 0.0;
    if (!ParseNumber(in.cell(r, c), &v)) {
      throw InputError(in.path, in.row_line[r],
                       fmt::format("column '{}' (mapped to {}): not a "
                                   "number: '{}'",
                                   in_name, out, in.cell(r, c)));
    }
    if (!std::isfinite(v)) {
      throw InputError(in.path, in.row_line[r],
                       fmt::format("column '{}' (mapped to {}): non-finite "
                                   "value '{}'",
                                   in_name, out, in.cell(r, c)));
    }
    values[r] = v * k;
  }
  return values;
}

// Phase 6 (values): the mapped columns, scaled, by output name (empty: not mapped).
std::vector<std::vector<double>> ReadMapped(const ImportOptions& o, const InputTable& in,
                                            const std::vector<std::string>& out_names,
                                            ImportReport& rep) {
  std::vector<std::vector<double>> in_values(out_names.size());
  for (std::size_t j = 0; j < out_names.size(); ++j) {
    if (const std::string* in_name = FindByName(o.map, out_names[j])) {
      in_values[j] = ReadColumn(o, in, out_names[j], *in_name);
      const double k = ScaleOf(o, out_names[j]);
      rep.mapping.push_back(k == 1.0 ? fmt::format("{} <- {}", out_names[j], *in_name)
                                     : fmt::format("{} <- {} x {:g}", out_names[j], *in_name, k));
    }
  }
  return in_values;
}

// Printed resolution of each time value [s]; the time must increase. Writers drop trailing
// zeros ("10.1" for 10.1000) and may vary the digits with magnitude (the NEES data set: 7
// decimals below 1e-3 s, 5 significant digits from 0.1 to 10 s, 4 decimals above), so the
// resolution of a value is 10^-(most decimals seen in its decade of magnitude); zero takes the
// finest of all.
std::vector<double> TimeResolution(const ImportOptions& o, const InputTable& in,
                                   const std::vector<double>& t) {
  const std::size_t tcol = in.column_of(*FindByName(o.map, std::string("t")));
  const auto decade = [](double v) { return static_cast<int>(std::floor(std::log10(v))); };
  std::map<int, int> decimals_in_decade;
  int max_decimals = 0;
  for (std::size_t r = 0; r < in.rows; ++r) {
    const int d = CountDecimals(in.cell(r, tcol));
    max_decimals = std::max(max_decimals, d);
    double printed = 0.0;
    ParseNumber(in.cell(r, tcol), &printed);
    if (printed != 0.0) {
      int& m = decimals_in_decade.try_emplace(decade(std::fabs(printed)), d).first->second;
      m = std::max(m, d);
    }
    if (r > 0 && !(t[r] > t[r - 1])) {
      throw InputError(in.path, in.row_line[r],
                       fmt::format("time '{}' is not increasing ({} s after {} s)", in.names[tcol],
                                   t[r], t[r - 1]));
    }
  }
  const double t_scale = std::fabs(ScaleOf(o, "t"));
  std::vector<double> res(in.rows);
  for (std::size_t r = 0; r < in.rows; ++r) {
    const double printed = std::fabs(t[r]) / t_scale;
    const int d = printed > 0.0 ? decimals_in_decade[decade(printed)] : max_decimals;
    res[r] = std::pow(10.0, -d) * t_scale;
  }
  return res;
}

// Phase 7 (time): strictly increasing, uniform within printed rounding + jitter; the rate by
// least squares [Hz].
double FitRate(const ImportOptions& o, const InputTable& in, const std::vector<double>& t,
               ImportReport& rep) {
  const std::vector<double> res = TimeResolution(o, in, t);
  const std::size_t rows = in.rows;
  const double n = static_cast<double>(rows);
  const double k_mean = 0.5 * (n - 1.0);
  double t_mean = 0.0;
  for (double v : t) t_mean += v;
  t_mean /= n;
  double skt = 0.0;
  double skk = 0.0;
  for (std::size_t r = 0; r < rows; ++r) {
    const double dk = static_cast<double>(r) - k_mean;
    skt += dk * (t[r] - t_mean);
    skk += dk * dk;
  }
  const double period = skt / skk;
  const double t0 = t_mean - period * k_mean;
  const auto tolerance = [&](std::size_t r) {
    // Rounding counts up to a quarter period, so that a missing sample (an interval off by
    // one period) always exceeds the two-row tolerance of the interval check.
    return std::min(0.5 * res[r], 0.25 * period) + o.max_jitter * period;
  };
  for (std::size_t r = 1; r < rows; ++r) {  // local check first: names a gap's own line
    const double d = t[r] - t[r - 1];
    if (std::fabs(d - period) > tolerance(r) + tolerance(r - 1)) {
      throw InputError(in.path, in.row_line[r],
                       fmt::format("non-uniform time: interval {:.7g} s, fitted period {:.7g} s "
                                   "(rounding and --max-jitter allow {:.3g} s)",
                                   d, period, tolerance(r) + tolerance(r - 1)));
    }
  }
  for (std::size_t r = 0; r < rows; ++r) {
    const double dev = std::fabs(t[r] - (t0 + period * static_cast<double>(r)));
    if (dev > tolerance(r)) {
      throw InputError(in.path, in.row_line[r],
                       fmt::format("time {:.9g} s is {:.3g} s off the uniform grid of the fitted "
                                   "rate {:.6f} Hz (rounding and --max-jitter allow {:.3g} s)",
                                   t[r], dev, 1.0 / period, tolerance(r)));
    }
    rep.t_max_deviation_s = std::max(rep.t_max_deviation_s, dev);
    rep.t_resolution_s = std::max(rep.t_resolution_s, res[r]);
  }
  const double rate = 1.0 / period;
  rep.in_rate_hz = rate;
  rep.t_start_s = t[0];
  return rate;
}

// Phase 8 (rate column): the rate it states (its first value) agrees with the fitted one.
void CheckStatedRate(const ImportOptions& o, const InputTable& in, std::size_t rate_col,
                     double rate, ImportReport& rep) {
  const auto it = std::find_if(rep.sparse_dropped.begin(), rep.sparse_dropped.end(),
                               [&](const SparseColumn& s) { return s.name == o.rate_column; });
  std::size_t line = 0;
  std::string text;
  if (it != rep.sparse_dropped.end()) {
    line = it->first_line;
    text = it->first_value;
  } else {  // a complete column: its first value
    line = in.row_line[0];
    text = std::string(in.cell(0, rate_col));
  }
  double stated = 0.0;
  if (!ParseNumber(text, &stated) || !(stated > 0.0) || !std::isfinite(stated)) {
    throw InputError(in.path, line,
                     fmt::format("rate column '{}': '{}' is not a positive number "
                                 "(--rate-column '' skips the check)",
                                 o.rate_column, text));
  }
  if (std::fabs(stated - rate) > 1e-3 * rate) {
    throw InputError(in.path, line,
                     fmt::format("rate column '{}' states {} Hz, the time column "
                                 "gives {:.6f} Hz ({:+.3f} %); fix the file or "
                                 "skip the check with --rate-column ''",
                                 o.rate_column, stated, rate, 100.0 * (stated - rate) / rate));
  }
  rep.stated_rate_hz = stated;
}

// Phase 9a: v derived from x (--derive-velocity), or the mapped column, in rep.velocity.
void Velocity(const ImportOptions& o, const std::vector<std::string>& out_names, double rate,
              std::vector<std::vector<double>>& in_values, ImportReport& rep) {
  const auto xi = static_cast<std::size_t>(std::find(out_names.begin(), out_names.end(), "x") -
                                           out_names.begin());
  const auto vi = xi + 1;  // kToolkitNames order: t, x, v
  if (o.derive_velocity) {
    in_values[vi] = DeriveVelocity(in_values[xi], rate, o.velocity_cutoff_hz);
    const double k = ScaleOf(o, "v");
    for (double& v : in_values[vi]) v *= k;
    const KaiserLowPass lp = VelocityFilter(o.velocity_cutoff_hz);
    rep.velocity = fmt::format(
        "derived from x at {:.6g} Hz: {}; then central differences (gain >= {:.4f} in the pass "
        "band)",
        rate, lp.Describe(rate),
        std::sin(2.0 * std::numbers::pi * lp.pass_hz() / rate) /
            (2.0 * std::numbers::pi * lp.pass_hz() / rate));
    rep.mapping.insert(
        rep.mapping.begin() + static_cast<std::ptrdiff_t>(vi),
        k == 1.0 ? std::string("v <- d/dt x") : fmt::format("v <- d/dt x x {:g}", k));
  } else {
    rep.velocity = fmt::format("column '{}'", *FindByName(o.map, std::string("v")));
  }
}

// Rows at the output rate: at least 2 (as every reader needs), at most kMaxImportRows.
constexpr double kMaxImportRows = 1e8;  // 4 GB of doubles for 5 columns
std::size_t OutputRows(const ImportOptions& o, std::size_t rows, double rate) {
  const double span = static_cast<double>(rows - 1) * o.out_rate_hz / rate;  // [output periods]
  if (!(span < kMaxImportRows)) {
    throw InputError(o.in_path, 0,
                     fmt::format("--rate {:g} Hz would write {:.3g} rows from {} rows at {:g} "
                                 "Hz (at most {:g})",
                                 o.out_rate_hz, span + 1.0, rows, rate, kMaxImportRows));
  }
  const std::size_t n = ResampledRows(rows, rate, o.out_rate_hz);
  if (n < 2) {
    throw InputError(o.in_path, 0,
                     fmt::format("--rate {:g} Hz keeps fewer than 2 rows of the {} rows at {:g} "
                                 "Hz ({:.6g} s)",
                                 o.out_rate_hz, rows, rate, static_cast<double>(rows - 1) / rate));
  }
  return n;
}

// Phase 9b: every signal resampled at the output rate through the anti-aliasing filter.
ImportResult ResampleAll(const ImportOptions& o, std::size_t rows, double rate,
                         const std::vector<std::string>& out_names,
                         const std::vector<std::vector<double>>& in_values, ImportReport& rep) {
  const KaiserLowPass aa = AntiAliasFilter(rate, o.out_rate_hz);
  rep.anti_alias = fmt::format(
      "{}; band-limited interpolation at the output instants (ratio {:.6g}, kernel tabulated "
      "at 1024 phases/sample, DC gain 1); ends extended by odd reflection",
      aa.Describe(rate), rate / o.out_rate_hz);
  ImportResult result;
  const std::size_t out_rows = OutputRows(o, rows, rate);
  result.names = out_names;
  result.columns.resize(out_names.size());
  result.columns[0].resize(out_rows);
  for (std::size_t r = 0; r < out_rows; ++r) {
    result.columns[0][r] = static_cast<double>(r) / o.out_rate_hz;
  }
  for (std::size_t j = 1; j < out_names.size(); ++j) {
    result.columns[j] = Resample(in_values[j], rate, o.out_rate_hz);
  }
  rep.rows_written = out_rows;
  rep.names = out_names;
  result.report = std::move(rep);
  return result;
}

}  // namespace

ImportResult Import(const ImportOptions& o) {
  ValidateImportOptions(o);
  InputTable in;
  in.path = o.in_path;
  ImportReport rep;
  rep.in_path = in.path;
  rep.out_rate_hz = o.out_rate_hz;
  ReadLines(in, rep);
  ReadHeader(o, in, rep);
  const std::vector<std::string> out_names = MapColumns(o, in);
  ReadRows(o, in, rep);
  const std::optional<std::size_t> rate_col = SortColumns(o, in, rep);
  std::vector<std::vector<double>> in_values = ReadMapped(o, in, out_names, rep);
  const double rate = FitRate(o, in, in_values[0], rep);
  if (rate_col) CheckStatedRate(o, in, *rate_col, rate, rep);
  try {
    Velocity(o, out_names, rate, in_values, rep);
    return ResampleAll(o, in.rows, rate, out_names, in_values, rep);
  } catch (const std::invalid_argument& e) {
    throw InputError(in.path, 0, e.what());
  }
}

std::string FormatImportReport(const ImportReport& r) {
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "import {}\n", r.in_path);
  fmt::format_to(out, "  rows: {} data lines, {} read, {} written\n", r.data_lines, r.rows_read,
                 r.rows_written);
  fmt::format_to(out, "  input rate: {:.6f} Hz fitted to the time column", r.in_rate_hz);
  if (r.stated_rate_hz) {
    fmt::format_to(out, " (stated {:g} Hz: {:+.1e} %)", *r.stated_rate_hz,
                   100.0 * (*r.stated_rate_hz - r.in_rate_hz) / r.in_rate_hz);
  }
  fmt::format_to(out,
                 "\n  input time: from {:g} s, printed to {:.3g} s, max deviation from the "
                 "uniform grid {:.3g} s ({:.3f} periods)\n",
                 r.t_start_s, r.t_resolution_s, r.t_max_deviation_s,
                 r.t_max_deviation_s * r.in_rate_hz);
  fmt::format_to(out, "  output rate: {:g} Hz, t from 0 s in steps of {:.9g} s\n", r.out_rate_hz,
                 1.0 / r.out_rate_hz);
  fmt::format_to(out, "  columns: {}\n", fmt::join(r.mapping, ", "));
  if (!r.ignored.empty()) {
    fmt::format_to(out, "  ignored (unmapped): {}\n", fmt::join(r.ignored, ", "));
  }
  fmt::format_to(out, "  repairs:\n");
  std::size_t repairs = 0;
  if (r.bom) {
    fmt::format_to(out, "    byte-order mark removed\n");
    ++repairs;
  }
  if (r.quoted_names > 0) {
    fmt::format_to(out, "    quoted header names unquoted: {}\n", r.quoted_names);
    ++repairs;
  }
  if (r.trailing_separators > 0) {
    fmt::format_to(out, "    trailing separators dropped: {} lines (header included)\n",
                   r.trailing_separators);
    ++repairs;
  }
  for (const SparseColumn& c : r.sparse_dropped) {
    if (c.filled == 0) {
      fmt::format_to(out, "    sparse column dropped: '{}' (empty in all {} rows)\n", c.name,
                     r.rows_read);
    } else {
      fmt::format_to(out,
                     "    sparse column dropped: '{}' (filled in {} of {} rows; first at "
                     "line {}: {})\n",
                     c.name, c.filled, r.rows_read, c.first_line, c.first_value);
    }
    ++repairs;
  }
  if (r.dropped_last_line) {
    fmt::format_to(out, "    incomplete last row dropped: line {} ({})\n", *r.dropped_last_line,
                   r.dropped_last_reason);
    ++repairs;
  }
  if (repairs == 0) fmt::format_to(out, "    none\n");
  fmt::format_to(out, "  anti-aliasing: {}\n", r.anti_alias);
  fmt::format_to(out, "  velocity: {}\n", r.velocity);
  return s;
}

}  // namespace mrd::host
