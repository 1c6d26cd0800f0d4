#include "mrd/host/csv.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "csv_tokenizer.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host {

bool DataSet::Has(const std::string& name) const {
  return std::find(names.begin(), names.end(), name) != names.end();
}

const std::vector<double>& DataSet::Column(const std::string& name) const {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end()) throw InputError(path, 1, fmt::format("missing column '{}'", name));
  return columns[static_cast<std::size_t>(it - names.begin())];
}

DataSet ReadCsv(const std::string& path, std::span<const std::string> required) {
  const std::string content = csv::ReadFile(path);
  const std::vector<csv::Line> lines = csv::SplitLines(content, path);
  DataSet ds;
  ds.path = path;

  if (lines.empty()) throw InputError(path, 1, "empty file (no header row)");
  std::vector<std::string_view> fields;
  csv::SplitFields(lines[0].text, ',', &fields);
  for (std::string_view name : fields) {
    if (name.empty()) throw InputError(path, 1, "empty column name in header");
    if (ds.Has(std::string(name))) {
      throw InputError(path, 1, fmt::format("duplicate column '{}'", name));
    }
    ds.names.emplace_back(name);
  }
  ds.columns.resize(ds.names.size());
  std::vector<std::string> need{"t"};
  need.insert(need.end(), required.begin(), required.end());
  for (const std::string& r : need) {
    if (!ds.Has(r)) {
      throw InputError(
          path, 1,
          fmt::format("missing column '{}' (header has: {})", r, fmt::join(ds.names, ",")));
    }
  }

  std::size_t lineno = 1;
  for (std::size_t li = 1; li < lines.size(); ++li) {
    lineno = lines[li].number;
    if (csv::Trim(lines[li].text).empty()) continue;  // blank lines (e.g. trailing newline)
    csv::SplitFields(lines[li].text, ',', &fields);
    if (fields.size() != ds.names.size()) {
      throw InputError(path, lineno,
                       fmt::format("expected {} fields, found {}", ds.names.size(), fields.size()));
    }
    for (std::size_t i = 0; i < fields.size(); ++i) {
      const std::string_view f = fields[i];
      double value = 0.0;
      const char* end = f.data() + f.size();
      const auto res = std::from_chars(f.data(), end, value);
      if (f.empty() || res.ec == std::errc::invalid_argument || res.ptr != end) {
        throw InputError(path, lineno,
                         fmt::format("column '{}': not a number: '{}'", ds.names[i], f));
      }
      if (res.ec == std::errc::result_out_of_range || !std::isfinite(value)) {
        throw InputError(path, lineno,
                         fmt::format("column '{}': non-finite value '{}'", ds.names[i], f));
      }
      // Far beyond any measurement; squared sums of such values would overflow to inf.
      if (std::fabs(value) > kMaxDataMagnitude) {
        throw InputError(path, lineno,
                         fmt::format("column '{}': value {} beyond +-1e100 (not a measurement)",
                                     ds.names[i], f));
      }
      ds.columns[i].push_back(value);
    }
  }
  if (ds.rows() < 2) throw InputError(path, lineno, "fewer than 2 data rows");

  // Time must increase uniformly. Line numbers: data row r is on file line r + 2 when there
  // are no blank lines, which the writer never produces; report that line.
  const std::vector<double>& t = ds.Column("t");
  ds.dt = t[1] - t[0];
  if (!(ds.dt > 0.0)) throw InputError(path, 3, "time 't' is not increasing");
  for (std::size_t r = 1; r < t.size(); ++r) {
    const double d = t[r] - t[r - 1];
    if (!(d > 0.0)) {
      throw InputError(path, r + 2,
                       fmt::format("time 't' is not increasing ({} after {})", t[r], t[r - 1]));
    }
    if (std::fabs(d - ds.dt) > 1e-3 * ds.dt) {
      throw InputError(
          path, r + 2,
          fmt::format("non-uniform sampling: interval {:.9g} s, expected {:.9g} s", d, ds.dt));
    }
  }
  return ds;
}

void WriteCsv(const std::string& path, const std::vector<std::string>& names,
              const std::vector<std::vector<double>>& columns) {
  if (names.size() != columns.size() || columns.empty()) {
    throw std::invalid_argument("WriteCsv: names and columns differ in count");
  }
  const std::size_t rows = columns.front().size();
  fmt::memory_buffer buf;
  fmt::format_to(std::back_inserter(buf), "{}\n", fmt::join(names, ","));
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (!std::isfinite(columns[c][r])) {
        // Data file line r + 2 (after the header); an overflowed scale or a diverging
        // simulation ends here, before anything is written.
        throw InputError(
            path, r + 2,
            fmt::format("column '{}': non-finite value {} not written", names[c], columns[c][r]));
      }
      // %.10g keeps 1e-10 relative precision; enough for simulated and measured signals.
      if (c > 0) buf.push_back(',');
      fmt::format_to(std::back_inserter(buf), "{:.10g}", columns[c][r]);
    }
    buf.push_back('\n');
  }
  WriteFileAtomic(path, fmt::to_string(buf));
}

}  // namespace mrd::host
