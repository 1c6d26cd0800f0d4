#include "mrd/profile/command_map.hpp"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "file_text.hpp"

namespace mrd::profile {
namespace {

bool ParseNumber(const std::string& s, double* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  while (end != nullptr && (*end == ' ' || *end == '\t' || *end == '\r')) ++end;
  if (end == nullptr || *end != '\0' || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

}  // namespace

bool CommandMap::LoadCalibration(const std::string& path, std::string* error) {
  std::string text;
  if (!ReadTextFile(path, 1u << 20, &text, error)) return false;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  std::size_t n = 0;
  const auto fail = [&](const std::string& why) {
    *error = path + ":" + std::to_string(line_no) + ": " + why;
    return false;
  };
  bool header = true;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    if (header) {  // "E,<unit>": the names are for people; two columns are required
      header = false;
      if (line.find(',') == std::string::npos)
        return fail("header: expected two columns (E,value)");
      continue;
    }
    const auto comma = line.find(',');
    double e = 0, u = 0;
    if (comma == std::string::npos || line.find(',', comma + 1) != std::string::npos ||
        !ParseNumber(line.substr(0, comma), &e) || !ParseNumber(line.substr(comma + 1), &u)) {
      return fail("expected two finite numbers: E,value");
    }
    if (n == kMaxPoints) return fail("more than 64 calibration points");
    if (n > 0 && !(e > e_[n - 1])) return fail("E must increase strictly");
    if (n > 1 && ((u_[n - 1] - u_[n - 2]) * (u - u_[n - 1]) <= 0.0)) {
      return fail("the calibration must be strictly monotonic (one value per E, no plateau)");
    }
    if (n == 1 && u == u_[0]) return fail("the calibration must be strictly monotonic");
    e_[n] = e;
    u_[n] = u;
    ++n;
  }
  if (n < 2) {
    *error = path + ": fewer than 2 calibration points";
    return false;
  }
  n_ = n;
  digest_ = TextDigest(text);
  return true;
}

bool CommandMap::SetRange(double min, double max, double slew_per_s, std::string* error) {
  if (!std::isfinite(min) || !std::isfinite(max) || !(min < max)) {
    *error = "command range: min must be below max (both finite)";
    return false;
  }
  if (!std::isfinite(slew_per_s) || slew_per_s < 0.0) {
    *error = "command slew_per_s: must be >= 0 (0: no limit)";
    return false;
  }
  min_ = min;
  max_ = max;
  slew_ = slew_per_s;
  return true;
}

double CommandMap::Calibrate(double e) const {
  if (n_ < 2) return e;
  if (e <= e_[0]) return u_[0];
  if (e >= e_[n_ - 1]) return u_[n_ - 1];
  std::size_t i = 1;
  while (e > e_[i]) ++i;  // e_[i-1] < e <= e_[i]
  const double t = (e - e_[i - 1]) / (e_[i] - e_[i - 1]);
  return u_[i - 1] + t * (u_[i] - u_[i - 1]);
}

double CommandMap::Invert(double u) const {
  if (n_ < 2) return u;
  const bool rising = u_[n_ - 1] > u_[0];
  const auto before = [rising](double a, double b) { return rising ? a <= b : a >= b; };
  if (before(u, u_[0])) return e_[0];
  if (before(u_[n_ - 1], u)) return e_[n_ - 1];
  std::size_t i = 1;
  while (!before(u, u_[i])) ++i;  // u between u_[i-1] and u_[i]
  const double t = (u - u_[i - 1]) / (u_[i] - u_[i - 1]);
  return e_[i - 1] + t * (e_[i] - e_[i - 1]);
}

double CommandMap::SafeSetpoint(double e) const {
  double u = std::isfinite(e) ? Calibrate(e) : 0.0;
  if (u < min_) u = min_;
  if (u > max_) u = max_;
  return u;
}

void CommandMap::Reach(double e_max, double* lo, double* hi) const {
  if (has_range()) {
    *lo = min_;
    *hi = max_;
    return;
  }
  const double a = SafeSetpoint(0.0), b = SafeSetpoint(e_max);
  *lo = a < b ? a : b;
  *hi = a < b ? b : a;
}

double CommandMap::Off() const {
  double lo = 0.0, hi = 0.0;
  // Without a range, the calibration's values for E >= 0 (held beyond its last point).
  Reach(n_ >= 2 ? e_[n_ - 1] + 1.0 : 0.0, &lo, &hi);
  return lo > 0.0 ? lo : hi < 0.0 ? hi : 0.0;
}

double CommandMap::Apply(double e, double dt_s) {
  double u = std::isfinite(e) ? Calibrate(e) : 0.0;
  if (u < min_) u = min_;
  if (u > max_) u = max_;
  if (slew_ > 0.0 && have_last_ && dt_s > 0.0) {
    const double step = slew_ * dt_s;
    if (u > last_ + step) u = last_ + step;
    if (u < last_ - step) u = last_ - step;
  }
  last_ = u;
  have_last_ = true;
  return u;
}

}  // namespace mrd::profile
