#include "mrd/common/ground_record.hpp"

#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "mrd/common/input_lines.hpp"

namespace mrd {

bool LoadGroundRecord(const std::string& path, GroundRecord* record, std::string* error) {
  InputLines lines;
  if (!lines.Read(path, std::uint64_t{64} << 20, error)) return false;
  std::vector<double> t, a;
  std::string line;
  bool header = false;
  const auto fail = [&](const std::string& why) { return lines.Fail(why, error); };
  while (lines.Next(&line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;
      if (line.rfind("t_s,ag_g", 0) != 0) return fail("expected the header t_s,ag_g");
      continue;
    }
    const char* s = line.c_str();
    char* end = nullptr;
    const double tv = std::strtod(s, &end);
    if (end == s || *end != ',') return fail("expected 't_s,ag_g' numbers");
    const char* s2 = end + 1;
    const double av = std::strtod(s2, &end);
    while (*end == ' ') ++end;
    if (end == s2 || *end != '\0' || !std::isfinite(tv) || !std::isfinite(av)) {
      return fail("expected 't_s,ag_g' numbers");
    }
    if (std::fabs(av) > 10.0) return fail("ground acceleration beyond 10 g");
    if (t.size() >= 2) {
      const double dt = t[1] - t[0];
      if (std::fabs((tv - t.back()) - dt) > 1e-6 * (1.0 + dt)) {
        return fail("samples are not equally spaced");
      }
    } else if (!t.empty() && !(tv > t.back())) {
      return fail("time does not increase");
    }
    t.push_back(tv);
    a.push_back(av);
  }
  if (t.size() < 2) {
    *error = lines.where() + ": fewer than 2 samples";
    return false;
  }
  record->path = path;
  record->ag_g = std::move(a);
  record->dt_s = t[1] - t[0];
  return true;
}

}  // namespace mrd
