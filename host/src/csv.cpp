#include "mrd/host/csv.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "mrd/host/input_error.hpp"

namespace mrd::host {
namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

std::vector<std::string_view> Split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    out.push_back(Trim(line.substr(start, comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
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
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open file");
  DataSet ds;
  ds.path = path;

  std::string line;
  if (!std::getline(in, line)) throw InputError(path, 1, "empty file (no header row)");
  for (std::string_view name : Split(line)) {
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
      throw InputError(path, 1, fmt::format("missing column '{}' (header has: {})", r,
                                            fmt::join(ds.names, ",")));
    }
  }

  std::size_t lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (Trim(line).empty()) continue;  // blank lines (e.g. trailing newline) are skipped
    const auto fields = Split(line);
    if (fields.size() != ds.names.size()) {
      throw InputError(path, lineno, fmt::format("expected {} fields, found {}",
                                                 ds.names.size(), fields.size()));
    }
    for (std::size_t i = 0; i < fields.size(); ++i) {
      const std::string_view f = fields[i];
      double value = 0.0;
      const char* end = f.data() + f.size();
      const auto res = std::from_chars(f.data(), end, value);
      if (f.empty() || res.ec == std::errc::invalid_argument || res.ptr != end) {
        throw InputError(path, lineno, fmt::format("column '{}': not a number: '{}'",
                                                   ds.names[i], f));
      }
      if (res.ec == std::errc::result_out_of_range || !std::isfinite(value)) {
        throw InputError(path, lineno, fmt::format("column '{}': non-finite value '{}'",
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
      throw InputError(path, r + 2, fmt::format("time 't' is not increasing ({} after {})",
                                                t[r], t[r - 1]));
    }
    if (std::fabs(d - ds.dt) > 1e-3 * ds.dt) {
      throw InputError(path, r + 2,
                       fmt::format("non-uniform sampling: interval {:.9g} s, expected {:.9g} s",
                                   d, ds.dt));
    }
  }
  return ds;
}

void WriteFileAtomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(fmt::format("{}: cannot open for writing", path));
    out << text;
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      throw std::runtime_error(fmt::format("{}: write failed", path));
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(fmt::format("{}: cannot rename temporary file", path));
  }
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
      // %.10g keeps 1e-10 relative precision; enough for simulated and measured signals.
      if (c > 0) buf.push_back(',');
      fmt::format_to(std::back_inserter(buf), "{:.10g}", columns[c][r]);
    }
    buf.push_back('\n');
  }
  WriteFileAtomic(path, fmt::to_string(buf));
}

}  // namespace mrd::host
