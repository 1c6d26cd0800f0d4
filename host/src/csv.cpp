#include "mrd/host/csv.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "csv_tokenizer.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host {

namespace {

// Time must increase uniformly: sets ds->dt from the first interval; at_row(r, reason) is the
// error of data row r (from 0).
template <class AtRow>
void CheckTime(DataSet* ds_ptr, const AtRow& at_row) {
  DataSet& ds = *ds_ptr;
  const std::vector<double>& t = ds.Column("t");
  ds.dt = t[1] - t[0];
  if (!(ds.dt > 0.0)) throw at_row(1, "time 't' is not increasing");
  for (std::size_t r = 1; r < t.size(); ++r) {
    const double d = t[r] - t[r - 1];
    if (!(d > 0.0)) {
      throw at_row(r, fmt::format("time 't' is not increasing ({} after {})", t[r], t[r - 1]));
    }
    if (std::fabs(d - ds.dt) > 1e-3 * ds.dt) {
      throw at_row(
          r, fmt::format("non-uniform sampling: interval {:.9g} s, expected {:.9g} s", d, ds.dt));
    }
  }
}

std::string NonFiniteReason(const std::string& column, std::string_view text) {
  return fmt::format("column '{}': non-finite value '{}'", column, text);
}

std::string MagnitudeReason(const std::string& column, std::string_view text) {
  return fmt::format("column '{}': value {} beyond +-1e100 (not a measurement)", column, text);
}

}  // namespace

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
        throw InputError(path, lineno, NonFiniteReason(ds.names[i], f));
      }
      // Far beyond any measurement; squared sums of such values would overflow to inf.
      if (std::fabs(value) > kMaxDataMagnitude) {
        throw InputError(path, lineno, MagnitudeReason(ds.names[i], f));
      }
      ds.columns[i].push_back(value);
    }
  }
  if (ds.rows() < 2) throw InputError(path, lineno, "fewer than 2 data rows");

  // Line numbers: data row r is on file line r + 2 when there are no blank lines, which the
  // writer never produces; report that line.
  CheckTime(&ds, [&](std::size_t row, const std::string& reason) {
    return InputError(path, row + 2, reason);
  });
  return ds;
}

DataSet MakeDataSet(const std::string& source, std::vector<std::string> names,
                    std::vector<std::vector<double>> columns,
                    std::span<const std::string> required) {
  if (names.size() != columns.size()) {
    throw std::invalid_argument("MakeDataSet: names and columns differ in count");
  }
  DataSet ds;
  ds.path = source;
  for (std::string& name : names) {
    if (name.empty()) throw InputError(source, 0, "empty column name");
    if (ds.Has(name)) throw InputError(source, 0, fmt::format("duplicate column '{}'", name));
    ds.names.push_back(std::move(name));
  }
  std::vector<std::string> need{"t"};
  need.insert(need.end(), required.begin(), required.end());
  for (const std::string& r : need) {
    if (!ds.Has(r)) {
      throw InputError(source, 0,
                       fmt::format("missing column '{}' (has: {})", r, fmt::join(ds.names, ",")));
    }
  }
  const std::size_t rows = columns.empty() ? 0 : columns.front().size();
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i].size() != rows) {
      throw InputError(source, 0,
                       fmt::format("column '{}' has {} rows, column '{}' has {}", ds.names[i],
                                   columns[i].size(), ds.names[0], rows));
    }
    for (std::size_t r = 0; r < rows; ++r) {
      const double v = columns[i][r];
      if (!std::isfinite(v)) {
        throw InputError(
            source, 0,
            fmt::format("row {}: {}", r, NonFiniteReason(ds.names[i], fmt::format("{}", v))));
      }
      if (std::fabs(v) > kMaxDataMagnitude) {
        throw InputError(
            source, 0,
            fmt::format("row {}: {}", r, MagnitudeReason(ds.names[i], fmt::format("{}", v))));
      }
    }
  }
  ds.columns = std::move(columns);
  if (rows < 2) throw InputError(source, 0, fmt::format("fewer than 2 data rows ({})", rows));
  CheckTime(&ds, [&](std::size_t row, const std::string& reason) {
    return InputError(source, 0, fmt::format("row {}: {}", row, reason));
  });
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
