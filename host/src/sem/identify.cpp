// Identify (the search path: sem/search/search_path.hpp), the data checks and channel scales,
// SimulateCost, SelectIteration and TransformSignal.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "mrd/host/input_error.hpp"
#include "mrd/host/sem.hpp"
#include "sem/estimate/replay.hpp"
#include "sem/internal.hpp"
#include "sem/search/search_path.hpp"

namespace mrd::host {

std::vector<double> internal::TransformSignal(const ElementaryRegressor& reg,
                                              const std::vector<double>& raw, double scale) {
  std::vector<double> out(raw.size());
  if (reg.transform == Transform::kLowPass) {
    const double a = LowPassPole(reg.exponent);
    double r = 0.0;
    for (std::size_t k = 0; k < raw.size(); ++k) out[k] = r = LowPassStep(a, r, raw[k] / scale);
    return out;
  }
  for (std::size_t k = 0; k < raw.size(); ++k) {
    out[k] = ApplyTransform(reg.transform, reg.exponent, raw[k] / scale);
  }
  return out;
}

namespace {

using internal::kInf;

std::size_t SignalLine(const SemSpec& spec, const std::string& signal) {
  if (signal == spec.output) return spec.output_line;
  for (const auto& r : spec.regressors) {
    if (r.signal == signal) return r.signal_line;
  }
  return 0;
}

}  // namespace

void internal::CheckData(const SemSpec& spec, std::span<const DataSet> data) {
  for (const auto& d : data) {
    for (const auto& s : spec.Signals()) {
      if (!d.Has(s)) {
        throw InputError(spec.path, SignalLine(spec, s),
                         fmt::format("unknown column '{}': not in data file {}", s, d.path));
      }
    }
    if (d.rows() <= static_cast<std::size_t>(spec.MaxDelay()) + 1) {
      throw InputError(d.path, 0,
                       fmt::format("{} rows: too short for the spec's largest delay {}", d.rows(),
                                   spec.MaxDelay()));
    }
  }
}

std::vector<ChannelInfo> ComputeScales(const SemSpec& spec, std::span<const DataSet> data) {
  internal::CheckData(spec, data);
  std::vector<ChannelInfo> out;
  for (const auto& s : spec.Signals()) {
    ChannelInfo c;
    c.name = s;
    double mx = 0.0;
    for (const auto& d : data) {
      for (double v : d.Column(s)) mx = std::max(mx, std::fabs(v));
    }
    c.scale = mx > 0.0 ? mx : 1.0;
    out.push_back(c);
  }
  return out;
}

double SimulateCost(const SemSpec& spec, const std::vector<ChannelInfo>& channels,
                    const std::vector<SemTerm>& terms, const std::vector<double>& coefficients,
                    const DataSet& data, std::vector<double>* ysim) {
  return internal::Replay(spec, channels, data).Run(terms, coefficients, ysim);
}

int SelectIteration(const std::vector<SemIteration>& its, double tolerance_percent) {
  if (its.empty()) return 0;
  auto score = [](const SemIteration& it) {
    if (it.validation_j.empty()) return it.j;
    double s = 0.0;
    for (double v : it.validation_j) s += v;
    return s;
  };
  auto failed = [](const SemIteration& it) { return FailsChecks(it); };
  double best = kInf;
  for (const auto& it : its) {
    if (!failed(it)) best = std::min(best, score(it));
  }
  const SemIteration* pick = nullptr;
  for (const auto& it : its) {
    if (failed(it)) continue;
    const double s = score(it);
    if (!(s <= best * (1.0 + tolerance_percent / 100.0))) continue;
    if (pick == nullptr || it.terms.size() < pick->terms.size() ||
        (it.terms.size() == pick->terms.size() && s < score(*pick))) {
      pick = &it;
    }
  }
  if (pick == nullptr) {
    for (auto it = its.rbegin(); it != its.rend(); ++it) {
      if (!failed(*it)) return it->iteration;  // every passing score is infinite
    }
    return -1;
  }
  return pick->iteration;
}

SemResult Identify(const SemSpec& spec, std::span<const DataSet> identification,
                   std::span<const DataSet> validation, const SemOptions& o) {
  internal::SearchPath path(spec, identification, validation, o);
  return path.Run();
}

}  // namespace mrd::host
