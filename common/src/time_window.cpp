#include "mrd/common/time_window.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>

namespace mrd {

bool ParseTimeWindow(std::string_view text, TimeWindow* window, std::string* why) {
  const std::string s(text);
  const auto colon = s.find(':');
  const auto number = [](const std::string& v, double* out) {
    char* end = nullptr;
    *out = std::strtod(v.c_str(), &end);
    return !v.empty() && end == v.c_str() + v.size() && std::isfinite(*out);
  };
  TimeWindow w;
  if (colon == std::string::npos || !number(s.substr(0, colon), &w.from_s) ||
      !number(s.substr(colon + 1), &w.to_s)) {
    *why = "'" + s + "': expected FROM:TO in seconds (e.g. 2:7)";
    return false;
  }
  if (!(w.from_s < w.to_s)) {
    *why = "'" + s + "': FROM must be below TO";
    return false;
  }
  *window = w;
  return true;
}

TimeWindow PlotWindow(const std::vector<double>& t, const TimeWindow* asked, std::string* note) {
  note->clear();
  if (t.empty()) return {0.0, kDefaultWindowS};
  const double t0 = t.front(), t1 = t.back();
  const TimeWindow first{t0, std::min(t1, t0 + kDefaultWindowS)};
  if (asked == nullptr) return first;
  const TimeWindow w{std::max(asked->from_s, t0), std::min(asked->to_s, t1)};
  if (!(w.from_s < w.to_s)) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "window %g:%g s is outside the record (%g .. %g s): the first %g s drawn",
                  asked->from_s, asked->to_s, t0, t1, kDefaultWindowS);
    *note = buf;
    return first;
  }
  return w;
}

SampleRange SamplesIn(const std::vector<double>& t, const TimeWindow& w) {
  SampleRange r;
  r.first = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), w.from_s) - t.begin());
  r.last = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), w.to_s) - t.begin());
  if (r.last < r.first) r.last = r.first;
  return r;
}

std::vector<double> Slice(const std::vector<double>& v, const SampleRange& r) {
  const std::size_t last = std::min(r.last, v.size());
  if (r.first >= last) return {};
  return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(r.first),
                             v.begin() + static_cast<std::ptrdiff_t>(last));
}

void Envelope(const std::vector<double>& t, const std::vector<double>& y, std::size_t buckets,
              std::vector<double>* t_out, std::vector<double>* y_out) {
  t_out->clear();
  y_out->clear();
  const std::size_t n = std::min(t.size(), y.size());
  if (n == 0 || buckets == 0) return;
  const std::size_t per = (n + buckets - 1) / buckets;
  for (std::size_t b = 0; b < n; b += per) {
    const std::size_t e = std::min(n, b + per);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, ts = 0.0;
    std::size_t finite = 0;
    for (std::size_t k = b; k < e; ++k) {
      ts += t[k];
      if (!std::isfinite(y[k])) continue;
      lo = std::min(lo, y[k]);
      hi = std::max(hi, y[k]);
      ++finite;
    }
    const double tm = ts / static_cast<double>(e - b);
    if (finite == 0) {
      t_out->push_back(tm);
      y_out->push_back(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    t_out->push_back(tm);
    y_out->push_back(lo);
    t_out->push_back(tm);
    y_out->push_back(hi);
  }
}

bool LooksPeriodic(const std::vector<double>& x) {
  constexpr std::size_t kMax = 4000;
  const std::size_t step = x.size() > kMax ? (x.size() + kMax - 1) / kMax : 1;
  std::vector<double> d;
  for (std::size_t k = 0; k < x.size(); k += step) {
    if (!std::isfinite(x[k])) return false;
    d.push_back(x[k]);
  }
  const std::size_t n = d.size();
  if (n < 16) return false;
  double mean = 0.0;
  for (const double v : d) mean += v;
  mean /= static_cast<double>(n);
  for (double& v : d) v -= mean;
  double r0 = 0.0;
  for (const double v : d) r0 += v * v;
  if (!(r0 > 0.0)) return false;  // constant
  bool crossed = false;
  for (std::size_t lag = 1; lag <= n / 2; ++lag) {
    double r = 0.0;
    for (std::size_t k = 0; k + lag < n; ++k) r += d[k] * d[k + lag];
    // Normalised by the overlap, so a lag late in the record is not penalised for its length.
    const double rho = r / r0 * static_cast<double>(n) / static_cast<double>(n - lag);
    if (!crossed) {
      crossed = rho < 0.0;
    } else if (rho > 0.9) {
      return true;
    }
  }
  return false;
}

}  // namespace mrd
