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

ImportResult Import(const ImportOptions& o) {
  ValidateImportOptions(o);
  const std::string& path = o.in_path;
  ImportReport rep;
  rep.in_path = path;
  rep.out_rate_hz = o.out_rate_hz;

  std::string content = csv::ReadFile(path);
  if (content.starts_with("\xEF\xBB\xBF")) {
    content.erase(0, 3);
    rep.bom = true;
  }
  const std::vector<Line> lines = csv::SplitLines(content, path);
  if (lines.empty() || Trim(lines[0].text).empty()) {
    throw InputError(path, 1, "empty file (no header row)");
  }

  // Header: names, quoted or not, optionally followed by a trailing separator.
  std::vector<std::string_view> fields;
  SplitFields(lines[0].text, o.separator, &fields);
  const bool trailing = fields.size() > 1 && fields.back().empty();
  if (trailing) {
    fields.pop_back();
    ++rep.trailing_separators;
  }
  std::vector<std::string> names;
  for (std::size_t c = 0; c < fields.size(); ++c) {
    std::string_view name = fields[c];
    if (!name.empty() && (name.front() == '"' || name.back() == '"')) {
      if (name.size() < 2 || name.front() != '"' || name.back() != '"') {
        throw InputError(path, 1, fmt::format("unbalanced quote in column name {}", name));
      }
      name = Trim(name.substr(1, name.size() - 2));
      ++rep.quoted_names;
    }
    if (name.empty()) throw InputError(path, 1, fmt::format("column {} has no name", c + 1));
    if (std::find(names.begin(), names.end(), name) != names.end()) {
      throw InputError(path, 1, fmt::format("duplicate column '{}'", name));
    }
    names.emplace_back(name);
  }
  const std::size_t ncol = names.size();
  const std::size_t expected = ncol + (trailing ? 1 : 0);

  // Map: output name -> input column index.
  const auto column_of = [&](const std::string& in_name) {
    const auto it = std::find(names.begin(), names.end(), in_name);
    return it == names.end() ? ncol : static_cast<std::size_t>(it - names.begin());
  };
  std::vector<std::string> out_names;  // t,x,v,E,f first, then the others in map order
  for (const std::string& n : kToolkitNames) out_names.push_back(n);
  for (const auto& [out, in] : o.map) {
    if (std::find(out_names.begin(), out_names.end(), out) == out_names.end()) {
      out_names.push_back(out);
    }
    if (column_of(in) == ncol) {
      throw InputError(path, 1,
                       fmt::format("--map {}={}: no column '{}' (columns: {})", out, in, in,
                                   fmt::join(names, ",")));
    }
  }
  std::vector<bool> mapped(ncol, false);
  for (const auto& p : o.map) mapped[column_of(p.second)] = true;

  // Data lines -> fields of the kept rows (row-major, views into content).
  std::vector<std::string_view> cells;
  std::vector<std::size_t> row_line;  // file line of each kept row
  rep.data_lines = lines.size() - 1;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const Line& line = lines[i];
    const bool is_last = i + 1 == lines.size();
    const bool blank = Trim(line.text).empty();
    SplitFields(line.text, o.separator, &fields);
    const std::size_t nf = blank ? 0 : fields.size();
    if (is_last) {  // an incomplete last row is dropped, with the reason
      std::string reason;
      if (blank) {
        reason = fmt::format("empty line, 0 of {} fields", ncol);
      } else if (trailing && nf == expected - 1) {
        reason = fmt::format(
            "no trailing separator where every other line has one: the last "
            "field '{}' may be truncated",
            fields.back());
      } else if (nf < expected) {
        reason = fmt::format("{} of {} fields", std::min(nf, ncol), ncol);
      } else if (nf == expected) {
        for (std::size_t c = 0; c < ncol && reason.empty(); ++c) {
          double value = 0.0;
          if (mapped[c] && !ParseNumber(fields[c], &value)) {
            reason = fmt::format("column '{}' is not a complete number: '{}'", names[c], fields[c]);
          }
        }
      }
      if (!reason.empty()) {
        rep.dropped_last_line = line.number;
        rep.dropped_last_reason = reason;
        break;
      }
    }
    if (blank) throw InputError(path, line.number, "blank line");
    if (nf != expected) {
      throw InputError(path, line.number,
                       fmt::format("expected {} fields{}, found {}", expected,
                                   trailing ? " (with the trailing separator)" : "", nf));
    }
    if (trailing) {
      if (!fields.back().empty()) {
        throw InputError(path, line.number,
                         fmt::format("value '{}' after the last named column", fields.back()));
      }
      ++rep.trailing_separators;
    }
    cells.insert(cells.end(), fields.begin(), fields.begin() + static_cast<std::ptrdiff_t>(ncol));
    row_line.push_back(line.number);
  }
  const std::size_t rows = row_line.size();
  rep.rows_read = rows;
  if (rows < 2) throw InputError(path, lines.back().number, "fewer than 2 data rows");
  const auto cell = [&](std::size_t r, std::size_t c) { return cells[r * ncol + c]; };

  // Columns: sparse ones dropped (an error when mapped), complete unmapped ones ignored.
  std::optional<std::size_t> rate_col;
  for (std::size_t c = 0; c < ncol; ++c) {
    std::size_t filled = 0;
    std::size_t first = rows;
    std::size_t first_empty = rows;
    for (std::size_t r = 0; r < rows; ++r) {
      if (cell(r, c).empty()) {
        first_empty = std::min(first_empty, r);
      } else {
        ++filled;
        first = std::min(first, r);
      }
    }
    if (mapped[c]) {
      if (filled < rows) {
        throw InputError(path, row_line[first_empty],
                         fmt::format("column '{}' (mapped) has no value", names[c]));
      }
      continue;
    }
    if (!o.rate_column.empty() && names[c] == o.rate_column && filled > 0) rate_col = c;
    if (filled < rows) {
      rep.sparse_dropped.push_back({names[c], filled, filled > 0 ? row_line[first] : 0,
                                    filled > 0 ? std::string(cell(first, c)) : std::string()});
    } else {
      rep.ignored.push_back(names[c]);
    }
  }

  // Mapped values, scaled.
  const auto scale_of = [&](const std::string& out) {
    const double* s = FindByName(o.scale, out);
    return s ? *s : 1.0;
  };
  const auto read_column = [&](const std::string& out, const std::string& in) {
    const std::size_t c = column_of(in);
    const double k = scale_of(out);
    std::vector<double> values(rows);
    for (std::size_t r = 0; r < rows; ++r) {
      double v = 0.0;
      if (!ParseNumber(cell(r, c), &v)) {
        throw InputError(path, row_line[r],
                         fmt::format("column '{}' (mapped to {}): not a "
                                     "number: '{}'",
                                     in, out, cell(r, c)));
      }
      if (!std::isfinite(v)) {
        throw InputError(path, row_line[r],
                         fmt::format("column '{}' (mapped to {}): non-finite "
                                     "value '{}'",
                                     in, out, cell(r, c)));
      }
      values[r] = v * k;
    }
    return values;
  };
  std::vector<std::vector<double>> in_values(out_names.size());
  for (std::size_t j = 0; j < out_names.size(); ++j) {
    if (const std::string* in = FindByName(o.map, out_names[j])) {
      in_values[j] = read_column(out_names[j], *in);
      const double k = scale_of(out_names[j]);
      rep.mapping.push_back(k == 1.0 ? fmt::format("{} <- {}", out_names[j], *in)
                                     : fmt::format("{} <- {} x {:g}", out_names[j], *in, k));
    }
  }

  // Time: strictly increasing, uniform within printed rounding + jitter; rate by least squares.
  const std::vector<double>& t = in_values[0];
  const std::size_t tcol = column_of(*FindByName(o.map, std::string("t")));
  // Printed resolution of each time value. Writers drop trailing zeros ("10.1" for 10.1000)
  // and may vary the digits with magnitude (this data set: 7 decimals below 1e-3 s, 5
  // significant digits from 0.1 to 10 s, 4 decimals above), so the resolution of a value is
  // 10^-(most decimals seen in its decade of magnitude); zero takes the finest of all.
  const auto decade = [](double v) { return static_cast<int>(std::floor(std::log10(v))); };
  std::map<int, int> decimals_in_decade;
  int max_decimals = 0;
  for (std::size_t r = 0; r < rows; ++r) {
    const int d = CountDecimals(cell(r, tcol));
    max_decimals = std::max(max_decimals, d);
    double printed = 0.0;
    ParseNumber(cell(r, tcol), &printed);
    if (printed != 0.0) {
      int& m = decimals_in_decade.try_emplace(decade(std::fabs(printed)), d).first->second;
      m = std::max(m, d);
    }
    if (r > 0 && !(t[r] > t[r - 1])) {
      throw InputError(path, row_line[r],
                       fmt::format("time '{}' is not increasing ({} s after {} s)", names[tcol],
                                   t[r], t[r - 1]));
    }
  }
  const double t_scale = std::fabs(scale_of("t"));
  std::vector<double> res(rows);
  for (std::size_t r = 0; r < rows; ++r) {
    const double printed = std::fabs(t[r]) / t_scale;
    const int d = printed > 0.0 ? decimals_in_decade[decade(printed)] : max_decimals;
    res[r] = std::pow(10.0, -d) * t_scale;
  }
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
      throw InputError(path, row_line[r],
                       fmt::format("non-uniform time: interval {:.7g} s, fitted period {:.7g} s "
                                   "(rounding and --max-jitter allow {:.3g} s)",
                                   d, period, tolerance(r) + tolerance(r - 1)));
    }
  }
  for (std::size_t r = 0; r < rows; ++r) {
    const double dev = std::fabs(t[r] - (t0 + period * static_cast<double>(r)));
    if (dev > tolerance(r)) {
      throw InputError(path, row_line[r],
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
  if (rate_col) {
    const auto it = std::find_if(rep.sparse_dropped.begin(), rep.sparse_dropped.end(),
                                 [&](const SparseColumn& s) { return s.name == o.rate_column; });
    std::size_t line = 0;
    std::string text;
    if (it != rep.sparse_dropped.end()) {
      line = it->first_line;
      text = it->first_value;
    } else {  // a complete column: its first value
      line = row_line[0];
      text = std::string(cell(0, *rate_col));
    }
    double stated = 0.0;
    if (!ParseNumber(text, &stated) || !(stated > 0.0) || !std::isfinite(stated)) {
      throw InputError(path, line,
                       fmt::format("rate column '{}': '{}' is not a positive number "
                                   "(--rate-column '' skips the check)",
                                   o.rate_column, text));
    }
    if (std::fabs(stated - rate) > 1e-3 * rate) {
      throw InputError(path, line,
                       fmt::format("rate column '{}' states {} Hz, the time column "
                                   "gives {:.6f} Hz ({:+.3f} %); fix the file or "
                                   "skip the check with --rate-column ''",
                                   o.rate_column, stated, rate, 100.0 * (stated - rate) / rate));
    }
    rep.stated_rate_hz = stated;
  }

  // Velocity, then resampling of every signal through the anti-aliasing filter.
  const auto xi = static_cast<std::size_t>(std::find(out_names.begin(), out_names.end(), "x") -
                                           out_names.begin());
  const auto vi = xi + 1;  // kToolkitNames order: t, x, v
  try {
    if (o.derive_velocity) {
      in_values[vi] = DeriveVelocity(in_values[xi], rate, o.velocity_cutoff_hz);
      const double k = scale_of("v");
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
    const KaiserLowPass aa = AntiAliasFilter(rate, o.out_rate_hz);
    rep.anti_alias = fmt::format(
        "{}; band-limited interpolation at the output instants (ratio {:.6g}, kernel tabulated "
        "at 1024 phases/sample, DC gain 1); ends extended by odd reflection",
        aa.Describe(rate), rate / o.out_rate_hz);
    ImportResult result;
    const std::size_t out_rows = ResampledRows(rows, rate, o.out_rate_hz);
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
  } catch (const std::invalid_argument& e) {
    throw InputError(path, 0, e.what());
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
