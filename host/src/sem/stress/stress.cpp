#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "mrd/host/sem_stress.hpp"
#include "sem/estimate/replay.hpp"

namespace mrd::host {
namespace {

bool Contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

// Triangle over [lo, hi] with the given period [samples], starting at lo.
double Triangle(std::size_t k, int period, double lo, double hi) {
  const double p = static_cast<double>(period);
  const double phase = std::fmod(static_cast<double>(k), p) / p;  // [0, 1)
  const double up = phase < 0.5 ? 2.0 * phase : 2.0 - 2.0 * phase;
  return lo + (hi - lo) * up;
}

// A stretch signal of the spec: an input that is listed in stretch_signals (every input not
// swept when the list is empty).
bool Stretched(const SemSpec& spec, const std::string& s) {
  const StressSpec& st = spec.stress;
  if (s == spec.output || Contains(st.sweep_signals, s)) return false;
  return st.stretch_signals.empty() || Contains(st.stretch_signals, s);
}

// [min, max] of each signal over all identification data.
std::vector<std::pair<double, double>> Ranges(const std::vector<std::string>& signals,
                                              std::span<const DataSet> identification) {
  std::vector<std::pair<double, double>> range(signals.size(), {0.0, 0.0});
  for (std::size_t i = 0; i < signals.size(); ++i) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& d : identification) {
      for (const double v : d.Column(signals[i])) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
    range[i] = {lo, hi};
  }
  return range;
}

}  // namespace

std::vector<DataSet> BuildStressData(const SemSpec& spec, std::span<const DataSet> identification) {
  std::vector<DataSet> out;
  const StressSpec& st = spec.stress;
  if (!st.enabled) return out;
  const auto signals = spec.Signals();
  const auto range = Ranges(signals, identification);
  const std::size_t hold = static_cast<std::size_t>(st.hold);
  for (const auto& d : identification) {
    DataSet a;
    a.path = d.path + " (stress: stretched, held)";
    a.names = signals;
    a.dt = d.dt;
    for (const auto& s : signals) {
      std::vector<double> col = d.Column(s);
      if (Stretched(spec, s)) {
        for (double& v : col) v *= st.stretch;
      }
      const double last = col.empty() ? 0.0 : col.back();
      col.insert(col.end(), hold, last);
      a.columns.push_back(std::move(col));
    }
    if (!st.sweep_signals.empty()) {
      DataSet b = a;
      b.path = d.path + " (stress: stretched, swept, held)";
      for (std::size_t i = 0; i < signals.size(); ++i) {
        if (!Contains(st.sweep_signals, signals[i])) continue;
        auto& col = b.columns[i];
        for (std::size_t k = 0; k < col.size(); ++k) {
          col[k] = Triangle(k, st.sweep_period, range[i].first, range[i].second);
        }
      }
      out.push_back(std::move(a));
      out.push_back(std::move(b));
    } else {
      out.push_back(std::move(a));
    }
  }
  return out;
}

std::vector<DataSet> BuildRestData(const SemSpec& spec, std::span<const DataSet> identification) {
  std::vector<DataSet> out;
  const std::size_t n = static_cast<std::size_t>(spec.stress.rest);
  if (!spec.stress.enabled || n == 0 || identification.empty()) return out;
  const auto signals = spec.Signals();
  const auto range = Ranges(signals, identification);
  double ymax = 0.0;
  for (const auto& d : identification) {
    for (const double y : d.Column(spec.output)) ymax = std::max(ymax, std::fabs(y));
  }
  std::string still;
  for (const auto& s : signals) {
    if (Stretched(spec, s)) still += (still.empty() ? "" : ", ") + s;
  }
  for (const bool at_max : {false, true}) {
    for (const double sign : {1.0, -1.0}) {
      DataSet r;
      r.path = fmt::format("rest ({} = 0, other inputs at their data {}, output from {:+g})",
                           still.empty() ? "no stretched signal" : still,
                           at_max ? "maximum" : "minimum", sign * ymax);
      r.names = signals;
      r.dt = identification.front().dt;
      for (std::size_t i = 0; i < signals.size(); ++i) {
        double v = sign * ymax;  // the output column only seeds the run
        if (signals[i] != spec.output) {
          v = Stretched(spec, signals[i]) ? 0.0 : (at_max ? range[i].second : range[i].first);
        }
        r.columns.emplace_back(n, v);
      }
      out.push_back(std::move(r));
    }
  }
  return out;
}

StressVerdict CheckStress(const SemSpec& spec, const std::vector<ChannelInfo>& channels,
                          const std::vector<SemTerm>& terms,
                          const std::vector<double>& coefficients,
                          std::span<const DataSet> stress) {
  std::vector<internal::Replay> prepared;
  for (const DataSet& d : stress) prepared.emplace_back(spec, channels, d);
  return internal::CheckStressPrepared(spec, terms, coefficients, prepared);
}

StressVerdict internal::CheckStressPrepared(const SemSpec& spec, const std::vector<SemTerm>& terms,
                                            const std::vector<double>& coefficients,
                                            const std::vector<Replay>& stress) {
  StressVerdict v;
  if (stress.empty()) return v;
  v.checked = true;
  // Bound in normalised units: channels[0].scale is the largest |output| of the data
  // (ComputeScales, offset 0).
  const double bound = spec.stress.force_bound;
  std::vector<double> ysim;
  for (const Replay& d : stress) {
    d.Run(terms, coefficients, &ysim);
    const std::size_t d0 = static_cast<std::size_t>(spec.MaxDelay());
    for (std::size_t k = d0; k < ysim.size(); ++k) {
      const double a = std::fabs(ysim[k]);
      if (!std::isfinite(a)) {
        v.peak = std::numeric_limits<double>::infinity();
        v.pass = false;
        v.reason = fmt::format("free run diverges on {} at sample {}", d.path(), k);
        return v;
      }
      v.peak = std::max(v.peak, a);
    }
    if (v.peak > bound) {
      v.pass = false;
      v.reason = fmt::format("|output| reaches {:.3g} x the data's largest on {} (bound {:g})",
                             v.peak, d.path(), bound);
      return v;
    }
  }
  return v;
}

bool internal::StressPassesPrepared(const SemSpec& spec, const std::vector<SemTerm>& terms,
                                    const std::vector<double>& coefficients,
                                    const std::vector<Replay>& stress) {
  const double bound = spec.stress.force_bound;
  // A run that ends past divergence_limit returns +inf though within a larger bound.
  if (!(spec.divergence_limit >= bound)) {
    return CheckStressPrepared(spec, terms, coefficients, stress).pass;
  }
  for (const Replay& d : stress) {
    // +inf: stopped at a sample beyond the bound or not finite, where CheckStressPrepared fails.
    if (!(d.Run(terms, coefficients, nullptr, bound) < std::numeric_limits<double>::infinity())) {
      return false;
    }
  }
  return true;
}

void RecordEnvelope(std::span<const DataSet> identification, std::vector<ChannelInfo>* channels) {
  for (auto& c : *channels) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& d : identification) {
      for (const double x : d.Column(c.name)) {
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
    }
    if (!(lo <= hi)) continue;  // no rows
    c.has_range = true;
    c.min = lo;
    c.max = hi;
  }
}

}  // namespace mrd::host
