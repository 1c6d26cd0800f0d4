#include "sem/estimate/replay.hpp"

#include <algorithm>
#include <cmath>

#include "sem/engine/engine.hpp"  // Pow
#include "sem/internal.hpp"

namespace mrd::host::internal {

Replay::Replay(const SemSpec& spec, const std::vector<ChannelInfo>& channels, const DataSet& data)
    : spec_(spec), path_(data.path) {
  const auto signals = spec.Signals();
  n_ = data.rows();
  d0_ = static_cast<std::size_t>(spec.MaxDelay());
  const auto& yc = data.Column(signals[0]);
  y_.resize(n_);
  w_.resize(n_);
  for (std::size_t k = 0; k < n_; ++k) {
    y_[k] = yc[k] / channels[0].scale;
    w_[k] = spec.weighting == CostWeighting::kRelative
                ? 1.0 / std::max(std::fabs(y_[k]), spec.floor)
                : 1.0;
  }
  input_.resize(spec.regressors.size());
  pow_index_.resize(spec.regressors.size());
  for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
    const auto& reg = spec.regressors[r];
    const std::size_t ci = static_cast<std::size_t>(
        std::find(signals.begin(), signals.end(), reg.signal) - signals.begin());
    if (ci == 0) continue;  // the output: from the simulation
    input_[r] = TransformSignal(reg, data.Column(reg.signal), channels[ci].scale);
    for (int p : reg.powers) {
      if (p < 1) continue;
      const auto pi = static_cast<std::size_t>(p);
      if (pow_index_[r].size() <= pi) pow_index_[r].resize(pi + 1, -1);
      if (pow_index_[r][pi] >= 0) continue;
      std::vector<double> col(n_);
      for (std::size_t k = 0; k < n_; ++k) col[k] = Pow(input_[r][k], p);
      pow_index_[r][pi] = static_cast<int>(pow_.size());
      pow_.push_back(std::move(col));
    }
  }
}

double Replay::Run(const std::vector<SemTerm>& terms, const std::vector<double>& coefficients,
                   std::vector<double>* ysim, double stop_above) const {
  // Per factor of every term, in order: a row-aligned column of its value to its power (an
  // input offered at that power), or the regressor to evaluate per row.
  struct F {
    const double* col;  // pow_ column, shifted by the delay; nullptr: evaluate
    const ElementaryRegressor* reg;
    const double* input;  // input_ (evaluate an input at an unoffered power); nullptr: output
    std::size_t delay;
    int power;
  };
  std::vector<F> fs;
  std::vector<std::size_t> first(terms.size() + 1, 0);
  for (std::size_t t = 0; t < terms.size(); ++t) {
    first[t] = fs.size();
    for (const auto& f : terms[t].factors) {
      const auto r = static_cast<std::size_t>(f.regressor);
      const auto d = static_cast<std::size_t>(f.delay);
      F x{nullptr, &spec_.regressors[r], nullptr, d, f.power};
      if (!input_[r].empty()) {
        x.input = input_[r].data();
        const auto pi = static_cast<std::size_t>(f.power);
        if (f.power >= 1 && pi < pow_index_[r].size() && pow_index_[r][pi] >= 0) {
          x.col = pow_[static_cast<std::size_t>(pow_index_[r][pi])].data();
        }
      }
      fs.push_back(x);
    }
  }
  first[terms.size()] = fs.size();
  std::vector<double> local;
  std::vector<double>& yh = ysim != nullptr ? *ysim : local;
  yh.assign(y_.begin(), y_.begin() + static_cast<std::ptrdiff_t>(std::min(d0_, n_)));
  yh.resize(n_, 0.0);
  double cost = 0.0;
  bool bad = false;
  const bool stop = std::isfinite(stop_above);
  for (std::size_t k = d0_; k < n_; ++k) {
    double v = 0.0;
    for (std::size_t t = 0; t < terms.size(); ++t) {
      double tv = 1.0;
      for (std::size_t i = first[t]; i < first[t + 1]; ++i) {
        const F& x = fs[i];
        const std::size_t kk = k - x.delay;
        if (x.col != nullptr) {
          tv *= x.col[kk];
        } else if (x.input != nullptr) {
          tv *= Pow(x.input[kk], x.power);
        } else {
          tv *= Pow(ApplyTransform(x.reg->transform, x.reg->exponent, yh[kk]), x.power);
        }
      }
      v += coefficients[t] * tv;
    }
    yh[k] = v;
    if (stop && !(std::fabs(v) <= stop_above)) return kInf;
    bad |= !(std::fabs(v) <= spec_.divergence_limit);
    const double e = y_[k] - v;
    cost += w_[k] * e * e;
  }
  if (bad || !std::isfinite(cost)) return kInf;
  return cost / static_cast<double>(n_ - d0_);
}

}  // namespace mrd::host::internal
