#pragma once
// One identification record prepared for free-run evaluation outside the search engine: the
// cross-validation (sem_selection.cpp) and the output-error refinement (sem_refine.cpp). Not
// public.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

#include "mrd/host/sem.hpp"
#include "sem_internal.hpp"

namespace mrd::host::internal {

inline double IntPow(double b, int p) {
  double v = 1.0;
  for (int i = 0; i < p; ++i) v *= b;
  return v;
}

// d ApplyTransform(t, e, s) / ds for the transforms an output regressor may carry; 0 where
// the transform is flat or has a corner (sign; clip at +-e; |s|^e at 0).
inline double TransformSlope(Transform t, double e, double s) {
  switch (t) {
    case Transform::kIdentity:
    case Transform::kLowPass:  // input channels only
      return 1.0;
    case Transform::kAbsPow:
      return s == 0.0 ? 0.0 : std::copysign(e * std::pow(std::fabs(s), e - 1.0), s);
    case Transform::kSign:
      return 0.0;
    case Transform::kTanh: {
      const double th = std::tanh(s / e);
      return (1.0 - th * th) / e;
    }
    case Transform::kClip:
      return std::fabs(s) < e ? 1.0 : 0.0;
  }
  return 0.0;
}

// One identification record prepared for cross-validation (normalised signals).
struct Record {
  std::vector<double> y;                   // measured output, every row
  std::vector<std::vector<double>> input;  // per regressor: transformed input (empty: output)
  std::vector<double> w;                   // cost weight per row, divided by the scored count
  std::size_t first = 0;                   // first scored row (spec.MaxDelay())
};

class Evaluator {
 public:
  Evaluator(const SemSpec& spec, const std::vector<ChannelInfo>& ch, const DataSet& d)
      : spec_(spec) {
    const auto signals = spec.Signals();
    const auto& y = d.Column(spec.output);
    rec_.y.resize(y.size());
    for (std::size_t k = 0; k < y.size(); ++k) rec_.y[k] = y[k] / ch[0].scale;
    rec_.input.resize(spec.regressors.size());
    for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
      const auto& reg = spec.regressors[r];
      if (reg.signal == spec.output) continue;
      const std::size_t ci = static_cast<std::size_t>(
          std::find(signals.begin(), signals.end(), reg.signal) - signals.begin());
      rec_.input[r] = internal::TransformSignal(reg, d.Column(reg.signal), ch[ci].scale);
    }
    rec_.first = static_cast<std::size_t>(spec.MaxDelay());
    const double nd = static_cast<double>(y.size() - rec_.first);
    rec_.w.resize(y.size());
    for (std::size_t k = 0; k < y.size(); ++k) {
      const double w = spec.weighting == CostWeighting::kRelative
                           ? 1.0 / std::max(std::fabs(rec_.y[k]), spec.floor)
                           : 1.0;
      rec_.w[k] = w / nd;
    }
  }

  const Record& record() const { return rec_; }

  // Value of a term at row k with the output history ys (measured or simulated).
  double Term(const SemTerm& t, const std::vector<double>& ys, std::size_t k) const {
    double v = 1.0;
    for (const auto& f : t.factors) {
      const auto& reg = spec_.regressors[static_cast<std::size_t>(f.regressor)];
      const std::size_t kk = k - static_cast<std::size_t>(f.delay);
      const auto& in = rec_.input[static_cast<std::size_t>(f.regressor)];
      const double x = in.empty() ? ApplyTransform(reg.transform, reg.exponent, ys[kk]) : in[kk];
      v *= IntPow(x, f.power);
    }
    return v;
  }

  // A structure prepared for free runs (the refinement's and the cross-validation's many runs
  // of one structure): per term, the product of its input factors over every row, and its
  // output factors.
  struct OutFactor {
    Transform transform;
    double exponent;
    std::size_t delay;
    int power;
  };
  struct Prepared {
    std::vector<std::vector<double>> input;  // [term][row]
    std::vector<std::vector<OutFactor>> out;  // [term]
  };
  Prepared Prepare(const std::vector<SemTerm>& terms) const {
    Prepared p;
    for (const SemTerm& t : terms) {
      std::vector<double> in(rec_.y.size(), 1.0);
      std::vector<OutFactor> out;
      for (const auto& f : t.factors) {
        const auto& reg = spec_.regressors[static_cast<std::size_t>(f.regressor)];
        const auto& x = rec_.input[static_cast<std::size_t>(f.regressor)];
        const auto d = static_cast<std::size_t>(f.delay);
        if (x.empty()) {
          out.push_back({reg.transform, reg.exponent, d, f.power});
          continue;
        }
        for (std::size_t k = d; k < in.size(); ++k) in[k] *= IntPow(x[k - d], f.power);
      }
      p.input.push_back(std::move(in));
      p.out.push_back(std::move(out));
    }
    return p;
  }

  // Weighted squared free-run error of a prepared structure over rows [a, b), seeded by the
  // measured output before a; +inf when the run leaves |y| <= divergence_limit or is not
  // finite. ys: scratch for the output history; residual (optional) receives y - ysim.
  // sens (optional; row-major, b - a rows of m) receives the sensitivities d ysim_k / d theta_j
  // for k in [a, b). The measured output before a does not depend on theta; after it, by the
  // chain rule through the output factors,
  //   s_j(k) = phi_j(k) + sum_d (d ysim_k / d ysim_{k-d}) s_j(k-d).
  // The cost and residual do not depend on whether sens is asked for.
  double FreeRun(const Prepared& p, const Eigen::VectorXd& theta, std::size_t a, std::size_t b,
                 std::vector<double>& ys, std::vector<double>* residual,
                 std::vector<double>* sens = nullptr) const {
    ys.assign(rec_.y.begin(), rec_.y.begin() + static_cast<std::ptrdiff_t>(b));
    const std::size_t m = p.input.size();
    std::size_t max_delay = 0, max_factors = 0;
    std::vector<double> phi, slope, g, dg;  // sensitivities only
    if (sens != nullptr) {
      for (const auto& out : p.out) {
        max_factors = std::max(max_factors, out.size());
        for (const OutFactor& f : out) max_delay = std::max(max_delay, f.delay);
      }
      sens->assign((b - a) * m, 0.0);
      phi.resize(m);
      slope.resize(max_delay + 1);
      g.resize(max_factors);
      dg.resize(max_factors);
    }
    double cost = 0.0;
    for (std::size_t k = a; k < b; ++k) {
      std::fill(slope.begin(), slope.end(), 0.0);
      double v = 0.0;
      for (std::size_t i = 0; i < m; ++i) {
        const auto& out = p.out[i];
        const double th = theta(static_cast<Eigen::Index>(i));
        double t = th * p.input[i][k];
        for (std::size_t q = 0; q < out.size(); ++q) {
          const OutFactor& f = out[q];
          const double yd = ys[k - f.delay];
          const double x = f.transform == Transform::kIdentity
                               ? yd
                               : ApplyTransform(f.transform, f.exponent, yd);
          const double gq = IntPow(x, f.power);
          t *= gq;
          if (sens != nullptr) {  // factor value and d factor / d y
            g[q] = gq;
            dg[q] = f.power * IntPow(x, f.power - 1) * TransformSlope(f.transform, f.exponent, yd);
          }
        }
        v += t;
        if (sens == nullptr) continue;
        double ph = p.input[i][k];
        for (std::size_t q = 0; q < out.size(); ++q) ph *= g[q];
        phi[i] = ph;
        for (std::size_t q = 0; q < out.size(); ++q) {  // product rule over the factors
          double d = th * p.input[i][k] * dg[q];
          for (std::size_t r = 0; r < out.size(); ++r) d *= r == q ? 1.0 : g[r];
          slope[out[q].delay] += d;
        }
      }
      if (!(std::fabs(v) <= spec_.divergence_limit)) return std::numeric_limits<double>::infinity();
      ys[k] = v;  // the simulated output feeds back
      const double e = rec_.y[k] - v;
      cost += rec_.w[k] * e * e;
      if (residual != nullptr) residual->push_back(e);
      if (sens == nullptr) continue;
      double* s = sens->data() + (k - a) * m;
      for (std::size_t j = 0; j < m; ++j) s[j] = phi[j];
      for (std::size_t d = 1; d <= max_delay && d <= k - a; ++d) {
        if (slope[d] == 0.0) continue;
        const double* sp = sens->data() + (k - a - d) * m;
        for (std::size_t j = 0; j < m; ++j) s[j] += slope[d] * sp[j];
      }
    }
    return std::isfinite(cost) ? cost : std::numeric_limits<double>::infinity();
  }

 private:
  const SemSpec& spec_;
  Record rec_;
};


}  // namespace mrd::host::internal
