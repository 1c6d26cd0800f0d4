#include "mrd/hil/plants/plant.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "mrd/common/input_file.hpp"

namespace mrd::hil {
namespace {
constexpr std::uint64_t kMaxTraceBytes = std::uint64_t{256} << 20;  // [bytes]
}  // namespace

TracePlant::TracePlant(const SpencerParams& params, Trace trace, double period_s, int substeps)
    : damper_(params, substeps), trace_(std::move(trace)), period_s_(period_s) {
  Reset();
}

std::size_t TracePlant::Row(std::size_t k) const {
  return std::min(k, trace_.x.empty() ? std::size_t{0} : trace_.x.size() - 1);
}

void TracePlant::Reset() {
  steps_ = 0;
  const double x0 = trace_.x.empty() ? 0.0 : trace_.x[0];
  const double v0 = trace_.v.empty() ? 0.0 : trace_.v[0];
  damper_.Reset(x0, 0.0);
  force_ = damper_.Force(x0, v0);
}

PlantSample TracePlant::Step(double volts) {
  if (trace_.x.empty()) return Sample();
  const std::size_t a = Row(steps_), b = Row(steps_ + 1);
  force_ = damper_.Step(period_s_, trace_.x[a], trace_.v[a], trace_.x[b], trace_.v[b], volts);
  ++steps_;
  return Sample();
}

PlantSample TracePlant::Probe(double volts) const {
  PlantSample s;
  s.t_s = static_cast<double>(steps_ + 1) * period_s_;
  if (trace_.x.empty()) return s;
  SpencerDamper copy = damper_;
  const std::size_t a = Row(steps_), b = Row(steps_ + 1);
  s.force = copy.Step(period_s_, trace_.x[a], trace_.v[a], trace_.x[b], trace_.v[b], volts);
  s.x = trace_.x[b];
  s.v = trace_.v[b];
  s.demand = trace_.demand[b];
  return s;
}

PlantSample TracePlant::Sample() const {
  PlantSample s;
  s.t_s = static_cast<double>(steps_) * period_s_;
  if (trace_.x.empty()) return s;
  const std::size_t k = Row(steps_);
  s.x = trace_.x[k];
  s.v = trace_.v[k];
  s.demand = trace_.demand[k];
  s.force = force_;
  return s;
}

bool LoadTrace(const std::string& path, const std::string& demand_column, Trace* trace,
               std::string* error) {
  // A regular file of at most kMaxTraceBytes (a FIFO or /dev/zero would never end).
  std::string text;
  if (!ReadInputFile(path, kMaxTraceBytes, &text, error)) return false;
  std::istringstream in(std::move(text));
  std::string line;
  if (!std::getline(in, line)) {
    *error = path + ":1: empty file (expected a header row naming x and v)";
    return false;
  }
  std::vector<std::string> names;
  {
    std::stringstream ss(line);
    std::string n;
    while (std::getline(ss, n, ',')) {
      while (!n.empty() && (n.back() == '\r' || n.back() == ' ')) n.pop_back();
      while (!n.empty() && n.front() == ' ') n.erase(n.begin());
      names.push_back(n);
    }
  }
  const auto col = [&](const std::string& n) -> int {
    const auto it = std::find(names.begin(), names.end(), n);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
  };
  const int cx = col("x"), cv = col("v"), ct = col("t");
  const int cd = demand_column.empty() ? -1 : col(demand_column);
  if (cx < 0 || cv < 0) {
    *error = path + ":1: header needs columns 'x' and 'v'";
    return false;
  }
  if (!demand_column.empty() && cd < 0) {
    *error = path + ":1: no column '" + demand_column + "' for the demand";
    return false;
  }
  Trace t;
  int lineno = 1;
  bool have_time = false;
  double last_time = 0.0;  // [s]
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line == "\r") continue;
    std::vector<double> row;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) {
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      while (end != nullptr && (*end == ' ' || *end == '\r')) ++end;
      if (end == cell.c_str() || *end != '\0' || !std::isfinite(v)) {
        *error = Printable(path) + ":" + std::to_string(lineno) + ": '" + Printable(cell) +
                 "' is not a finite number";
        return false;
      }
      row.push_back(v);
    }
    if (row.size() != names.size()) {
      *error = path + ":" + std::to_string(lineno) + ": " + std::to_string(row.size()) +
               " fields, header has " + std::to_string(names.size());
      return false;
    }
    if (ct >= 0) {  // one row per period: a trace at another rate would play slower or faster
      const double time = row[static_cast<std::size_t>(ct)];
      if (have_time && std::fabs(time - last_time - kTracePeriodS) > 1e-3 * kTracePeriodS) {
        *error = Printable(path) + ":" + std::to_string(lineno) + ": t steps by " +
                 std::to_string(time - last_time) +
                 " s; the harness plays one row per 1 ms period (resample: mrd import --rate "
                 "1000)";
        return false;
      }
      have_time = true;
      last_time = time;
    }
    // Bounds far beyond any bench, so a squared sum cannot overflow: x [cm], v [cm/s], d [N].
    const double x = row[static_cast<std::size_t>(cx)], v = row[static_cast<std::size_t>(cv)];
    const double d = cd >= 0 ? row[static_cast<std::size_t>(cd)] : 0.0;
    if (std::fabs(x) > 1e4 || std::fabs(v) > 1e6 || std::fabs(d) > 1e9) {
      *error = Printable(path) + ":" + std::to_string(lineno) +
               ": beyond |x| <= 1e4 cm, |v| <= 1e6 cm/s, |demand| <= 1e9 N";
      return false;
    }
    t.x.push_back(x);
    t.v.push_back(v);
    t.demand.push_back(d);
  }
  if (t.x.size() < 2) {
    *error = path + ":" + std::to_string(lineno) + ": needs at least two data rows";
    return false;
  }
  *trace = std::move(t);
  return true;
}

}  // namespace mrd::hil
