#include "mrd/structure/reference.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "mrd/common/input_file.hpp"
#include "mrd/common/input_lines.hpp"

namespace mrd::structure {

const std::array<const char*, kReferenceColumns> kReferenceColumnNames = {
    "x1", "x2", "x3", "d1", "d2", "d3", "xa1", "xa2", "xa3", "f"};

namespace {

constexpr char kHeader[] = "case,x1,x2,x3,d1,d2,d3,xa1,xa2,xa3,f";
constexpr std::uint64_t kMaxReferenceBytes = std::uint64_t{1} << 20;  // a table, not data
constexpr double kSameChangePercent = 5.0;  // changes within +-5 % count as "no change"
constexpr Case kCases[] = {Case::kUncontrolled, Case::kPassiveOff, Case::kPassiveOn,
                           Case::kClippedOptimal};

std::vector<std::string> SplitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::stringstream ss(line);
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

std::string Trim(std::string s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\r' || s.back() == '\t')) s.pop_back();
  std::size_t i = 0;
  while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
  return s.substr(i);
}

bool CaseFromName(const std::string& name, Case* out) {
  for (const Case c : kCases) {
    if (name == CaseName(c)) {
      *out = c;
      return true;
    }
  }
  return false;
}

// Measured peak of column j.
double Peak(const Response& r, std::size_t j) {
  if (j < 3) return r.peak_x_cm[j];
  if (j < 6) return r.peak_d_cm[j - 3];
  if (j < 9) return r.peak_xa_cm_s2[j - 6];
  return r.peak_force_n;
}

const Response* Find(const std::vector<Response>& rows, Case c) {
  for (const Response& r : rows) {
    if (r.which == c) return &r;
  }
  return nullptr;
}

const ReferenceRow* Find(const std::vector<ReferenceRow>& rows, Case c) {
  for (const ReferenceRow& r : rows) {
    if (r.which == c) return &r;
  }
  return nullptr;
}

std::string Fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

int Sign(double change_percent) {
  if (std::fabs(change_percent) <= kSameChangePercent) return 0;
  return change_percent > 0.0 ? 1 : -1;
}

}  // namespace

bool LoadReference(const std::string& path, Reference* out, std::string* error) {
  InputLines lines;
  if (!lines.Read(path, kMaxReferenceBytes, error)) return false;
  const std::string& where = lines.where();
  Reference ref;
  ref.path = where;
  std::string line;
  bool header = false;
  const auto fail = [&](const std::string& why) { return lines.Fail(why, error); };
  while (lines.Next(&line)) {
    if (Trim(line).empty()) continue;
    if (line[0] == '#') {
      if (ref.source.empty()) ref.source = Printable(Trim(line.substr(1)));
      continue;
    }
    if (!header) {
      if (Trim(line) != kHeader) return fail(std::string("expected the header ") + kHeader);
      header = true;
      continue;
    }
    const std::vector<std::string> cells = SplitCells(line);
    if (cells.size() != kReferenceColumns + 1) {
      return fail("expected " + std::to_string(kReferenceColumns + 1) + " cells, found " +
                  std::to_string(cells.size()));
    }
    ReferenceRow row;
    const std::string name = Trim(cells[0]);
    if (!CaseFromName(name, &row.which)) {
      return fail("unknown case '" + Printable(name) +
                  "' (uncontrolled, passive-off, passive-on, clipped-optimal)");
    }
    if (Find(ref.rows, row.which) != nullptr) return fail("case '" + name + "' given twice");
    for (std::size_t j = 0; j < kReferenceColumns; ++j) {
      const std::string cell = Trim(cells[j + 1]);
      if (cell.empty()) continue;
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      if (end != cell.c_str() + cell.size() || !std::isfinite(v) || v < 0.0) {
        return fail(std::string(kReferenceColumnNames[j]) + " '" + Printable(cell) +
                    "' is not a peak (a number >= 0, or empty)");
      }
      row.value[j] = v;
      row.given[j] = true;
    }
    ref.rows.push_back(row);
  }
  // Whole-file reasons name no line (an empty file has none).
  if (!header) {
    *error = where + ": no header " + kHeader;
    return false;
  }
  if (ref.rows.empty()) {
    *error = where + ": no case rows";
    return false;
  }
  *out = ref;
  return true;
}

ReferenceCheck CompareWithReference(const std::vector<Response>& measured,
                                    const Reference& reference, double tolerance_percent) {
  ReferenceCheck check;
  std::ostringstream o;
  o << "Against the reference (" << reference.path << ")"
    << (reference.source.empty() ? std::string() : ": " + reference.source)
    << "\npeak measured / reference / difference [%]; * outside +-" << Fmt("%g", tolerance_percent)
    << " %:\n\n| case |";
  for (const char* name : kReferenceColumnNames) o << ' ' << name << " |";
  o << "\n|---|";
  for (std::size_t j = 0; j < kReferenceColumns; ++j) o << "---|";
  o << '\n';
  for (const ReferenceRow& ref : reference.rows) {
    const Response* m = Find(measured, ref.which);
    if (m == nullptr) continue;
    o << "| " << CaseName(ref.which) << " |";
    for (std::size_t j = 0; j < kReferenceColumns; ++j) {
      if (!ref.given[j]) {
        o << " — |";
        continue;
      }
      const double v = Peak(*m, j);
      const double r = ref.value[j];
      ++check.cells;
      const bool both_zero = r == 0.0 && v == 0.0;
      const double diff = r != 0.0 ? 100.0 * (v - r) / r : 0.0;
      const bool outside = !both_zero && (r == 0.0 || std::fabs(diff) > tolerance_percent);
      if (outside) ++check.outside;
      o << ' ' << Fmt("%.4g", v) << " / " << Fmt("%.4g", r) << " / "
        << (r != 0.0 ? Fmt("%+.1f", diff) : std::string(both_zero ? "0" : "n/a"))
        << (outside ? "*" : "") << " |";
    }
    o << '\n';
  }
  // How clipped-optimal changes each peak against each passive case, there and here.
  const ReferenceRow* ref_co = Find(reference.rows, Case::kClippedOptimal);
  const Response* m_co = Find(measured, Case::kClippedOptimal);
  std::ostringstream changes;
  for (const Case passive : {Case::kPassiveOff, Case::kPassiveOn}) {
    const ReferenceRow* ref_p = Find(reference.rows, passive);
    const Response* m_p = Find(measured, passive);
    if (ref_co == nullptr || ref_p == nullptr || m_co == nullptr || m_p == nullptr) continue;
    changes << "| vs " << CaseName(passive) << " |";
    for (std::size_t j = 0; j < kReferenceColumns; ++j) {
      if (!ref_co->given[j] || !ref_p->given[j] || ref_p->value[j] == 0.0 || Peak(*m_p, j) == 0.0) {
        changes << " — |";
        continue;
      }
      const double r = 100.0 * (ref_co->value[j] - ref_p->value[j]) / ref_p->value[j];
      const double v = 100.0 * (Peak(*m_co, j) - Peak(*m_p, j)) / Peak(*m_p, j);
      const bool same = Sign(r) == Sign(v);
      ++check.changes;
      if (same) ++check.changes_matched;
      changes << ' ' << Fmt("%+.0f", v) << " / " << Fmt("%+.0f", r) << (same ? "" : "*") << " |";
    }
    changes << '\n';
  }
  if (check.changes > 0) {
    o << "\nclipped-optimal's change of each peak, measured / reference [%]; * a different "
         "direction (changes within +-"
      << Fmt("%g", kSameChangePercent) << " % count as none):\n\n| against |";
    for (const char* name : kReferenceColumnNames) o << ' ' << name << " |";
    o << "\n|---|";
    for (std::size_t j = 0; j < kReferenceColumns; ++j) o << "---|";
    o << '\n' << changes.str();
  }
  o << '\n'
    << check.cells - check.outside << " of " << check.cells << " cells within +-"
    << Fmt("%g", tolerance_percent) << " %; " << check.changes_matched << " of " << check.changes
    << " clipped-optimal changes in the reference's direction\n";
  check.table = o.str();
  return check;
}

}  // namespace mrd::structure
