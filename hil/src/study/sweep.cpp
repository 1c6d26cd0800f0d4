#include "mrd/hil/study/sweep.hpp"

#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include "mrd/common/input_file.hpp"

namespace mrd::hil {
namespace {

bool ParseNumber(const std::string& text, double* out) {
  if (text.empty()) return false;
  try {
    std::size_t n = 0;
    *out = std::stod(text, &n);
    return n == text.size() && std::isfinite(*out);
  } catch (const std::exception&) {
    return false;
  }
}

std::string Number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v == 0.0 ? 0.0 : v);  // no "-0"
  return buf;
}

// FROM:TO:STEP -> the values; false with *why.
bool ParseRange(const std::string& text, std::vector<std::string>* values, std::string* why) {
  const auto c1 = text.find(':');
  const auto c2 = text.find(':', c1 + 1);
  if (c2 == std::string::npos || text.find(':', c2 + 1) != std::string::npos) {
    *why = "a range is FROM:TO:STEP";
    return false;
  }
  double from = 0.0, to = 0.0, step = 0.0;
  if (!ParseNumber(text.substr(0, c1), &from) ||
      !ParseNumber(text.substr(c1 + 1, c2 - c1 - 1), &to) ||
      !ParseNumber(text.substr(c2 + 1), &step)) {
    *why = "FROM, TO and STEP must be finite numbers";
    return false;
  }
  if (step == 0.0) {
    *why = "STEP must not be 0";
    return false;
  }
  if ((to - from) * step < 0.0) {
    *why = std::string("STEP must be ") + (to > from ? "positive" : "negative") +
           " to go from FROM to TO";
    return false;
  }
  const double span = (to - from) / step;  // >= 0
  if (!(span < static_cast<double>(kMaxSweepPoints))) {
    *why = "more than " + std::to_string(kMaxSweepPoints) + " points";
    return false;
  }
  const auto n = static_cast<std::size_t>(std::floor(span + 1e-9)) + 1;
  for (std::size_t i = 0; i < n; ++i)
    values->push_back(Number(from + static_cast<double>(i) * step));
  return true;
}

std::string Fixed(double v, int decimals) {
  if (std::isnan(v)) return "-";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

std::vector<std::vector<std::string>> SweepGrid::Points() const {
  std::vector<std::vector<std::string>> points;
  std::size_t total = 1;
  for (const SweepAxis& a : axes) total *= a.values.size();
  for (std::size_t p = 0; p < total; ++p) {
    std::vector<std::string> sets;
    std::size_t rest = p;
    for (const SweepAxis& a : axes) {  // the first axis varies fastest
      sets.push_back(a.key + "=" + a.values[rest % a.values.size()]);
      rest /= a.values.size();
    }
    points.push_back(std::move(sets));
  }
  return points;
}

bool ParseSweepGrid(const std::vector<std::string>& sets, SweepGrid* grid, std::string* error) {
  SweepGrid g;
  std::set<std::string> swept;
  std::size_t total = 1;
  for (const std::string& spec : sets) {
    const std::string label = "--set " + Printable(spec);
    const auto eq = spec.find('=');
    if (eq == std::string::npos || eq == 0) {
      *error = label + ": expected KEY=VALUE or KEY=FROM:TO:STEP";
      return false;
    }
    const std::string key = spec.substr(0, eq), value = spec.substr(eq + 1);
    const bool quoted = !value.empty() && (value[0] == '"' || value[0] == '\'');
    if (quoted || value.find(':') == std::string::npos) {
      g.fixed.push_back(spec);
      continue;
    }
    SweepAxis axis{key, {}};
    std::string why;
    if (!ParseRange(value, &axis.values, &why)) {
      *error = label + ": " + why;
      return false;
    }
    if (!swept.insert(key).second) {
      *error = label + ": '" + Printable(key) + "' is swept twice";
      return false;
    }
    total *= axis.values.size();
    if (total > kMaxSweepPoints) {
      *error = label + ": the grid has more than " + std::to_string(kMaxSweepPoints) + " points";
      return false;
    }
    g.axes.push_back(std::move(axis));
  }
  if (g.axes.empty()) {
    *error = "sweep needs at least one --set KEY=FROM:TO:STEP";
    return false;
  }
  *grid = std::move(g);
  return true;
}

SweepScores ScoresOf(const RunResult& r) {
  SweepScores s;
  s.pass = r.pass;
  s.invariant_violations = r.invariant_violations;
  s.error_all = r.tracking.error_all;
  s.error_reachable = r.tracking.error_reachable;
  s.reachable_share = r.tracking.reachable_share;
  if (r.ride) {
    s.ride = true;
    s.body_accel_rms = r.ride->controlled.body_accel_rms;
    s.travel_rms_cm = r.ride->controlled.travel_rms_cm;
    s.tyre_load_rms_n = r.ride->controlled.tyre_load_rms_n;
    s.body_accel_off = r.ride->passive_off.body_accel_rms;
    s.body_accel_on = r.ride->passive_on.body_accel_rms;
  }
  return s;
}

std::size_t BestPoint(const std::vector<SweepScores>& rows) {
  std::size_t best = rows.size();
  const auto score = [](const SweepScores& s) {
    return s.ride ? s.body_accel_rms : s.error_reachable;
  };
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (best == rows.size()) {
      best = i;
      continue;
    }
    const SweepScores &a = rows[i], &b = rows[best];
    if (a.pass != b.pass ? a.pass : score(a) < score(b)) best = i;  // ties: the first
  }
  return best;
}

namespace {
// One CSV cell: quoted when it holds a comma, a quote or a line break.
std::string CsvCell(const std::string& v) {
  if (v.find_first_of(",\"\n\r") == std::string::npos) return v;
  std::string q = "\"";
  for (const char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}
}  // namespace

std::string SweepCsv(const SweepGrid& grid, const std::vector<SweepScores>& rows) {
  std::ostringstream o;
  const bool ride = !rows.empty() && rows[0].ride;
  for (const SweepAxis& a : grid.axes) o << a.key << ',';
  o << "pass,invariant_violations,error_all,error_reachable,reachable_share";
  if (ride)
    o << ",body_accel_rms,travel_rms_cm,tyre_load_rms_n,body_accel_rms_off,body_accel_rms_on";
  o << ",table,plant\n";
  o.precision(9);
  const auto points = grid.Points();
  for (std::size_t i = 0; i < rows.size() && i < points.size(); ++i) {
    for (const std::string& set : points[i]) o << set.substr(set.find('=') + 1) << ',';
    const SweepScores& s = rows[i];
    o << (s.pass ? 1 : 0) << ',' << s.invariant_violations << ',';
    if (ride) {
      o << ",,";  // a quarter car has no tracking error: those cells empty
    } else {
      o << s.error_all << ',' << s.error_reachable << ',' << s.reachable_share;
    }
    if (ride) {
      o << ',' << s.body_accel_rms << ',' << s.travel_rms_cm << ',' << s.tyre_load_rms_n << ','
        << s.body_accel_off << ',' << s.body_accel_on;
    }
    o << ',' << CsvCell(s.table) << ',' << CsvCell(s.plant) << '\n';
  }
  return o.str();
}

std::string SweepTable(const SweepGrid& grid, const std::vector<SweepScores>& rows) {
  const bool ride = !rows.empty() && rows[0].ride;
  std::vector<std::string> head;
  for (const SweepAxis& a : grid.axes) head.push_back(a.key);
  head.push_back("pass");
  if (ride) {
    for (const char* h : {"body_accel_rms", "travel_rms_cm", "tyre_load_rms_n", "better_than_off",
                          "better_than_on"}) {
      head.push_back(h);
    }
  } else {
    head.push_back("error_all");
    head.push_back("error_reachable");
    head.push_back("reachable_share");
  }
  std::vector<std::vector<std::string>> cells;
  const auto points = grid.Points();
  const std::size_t best = BestPoint(rows);
  for (std::size_t i = 0; i < rows.size() && i < points.size(); ++i) {
    std::vector<std::string> row;
    for (const std::string& set : points[i]) row.push_back(set.substr(set.find('=') + 1));
    const SweepScores& s = rows[i];
    row.push_back(s.pass ? "PASS" : "FAIL");
    if (ride) {
      row.push_back(Fixed(s.body_accel_rms, 4));
      row.push_back(Fixed(s.travel_rms_cm, 4));
      row.push_back(Fixed(s.tyre_load_rms_n, 1));
      // Body acceleration RMS against the passive twins, + is better (as mrd-hil run says).
      row.push_back(Fixed(100.0 * (1.0 - s.body_accel_rms / s.body_accel_off), 1) + "%");
      row.push_back(Fixed(100.0 * (1.0 - s.body_accel_rms / s.body_accel_on), 1) + "%");
    } else {
      row.push_back(Fixed(s.error_all, 4));
      row.push_back(Fixed(s.error_reachable, 4));
      row.push_back(Fixed(100.0 * s.reachable_share, 1) + "%");
    }
    if (i == best) row.back() += "  <- best";
    cells.push_back(std::move(row));
  }
  std::vector<std::size_t> width(head.size());
  for (std::size_t c = 0; c < head.size(); ++c) {
    width[c] = head[c].size();
    for (const auto& row : cells) {
      if (c + 1 < head.size()) width[c] = std::max(width[c], row[c].size());
    }
  }
  std::ostringstream o;
  const auto line = [&](const std::vector<std::string>& r) {
    for (std::size_t c = 0; c < r.size(); ++c) {
      o << r[c];
      if (c + 1 < r.size()) o << std::string(width[c] - r[c].size() + 2, ' ');
    }
    o << '\n';
  };
  line(head);
  for (const auto& row : cells) line(row);
  return o.str();
}

}  // namespace mrd::hil
