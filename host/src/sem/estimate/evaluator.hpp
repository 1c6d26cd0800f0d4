#pragma once
// One identification record prepared for free-run evaluation outside the search engine: the
// cross-validation (host/src/sem/select/selection.cpp) and the output-error refinement
// (host/src/sem/estimate/refine.cpp). Not public.

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "mrd/host/sem.hpp"
#include "sem/internal.hpp"

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
  // of one structure). Terms are grouped by their output factors (the signature: which
  // transformed, delayed outputs to which powers); a group's input parts sum to one
  // coefficient signal c_g(k) = sum_i theta_i u_i(k) before the run, so the sample loop only
  // evaluates each slot (one transform of one delayed output) and each group once:
  //   ysim(k) = sum_g c_g(k) prod_{(s, p) in g} x_s(k)^p.
  struct Slot {
    Transform transform;
    double exponent;
    std::size_t delay;
    int max_power;
  };
  struct Group {
    std::vector<std::pair<std::size_t, int>> factors;  // (slot, power)
    std::vector<std::size_t> terms;
  };
  struct Prepared {
    std::size_t m = 0;          // terms
    std::vector<double> input;  // [row * m + term]: product of the term's input factors
    std::vector<Slot> slots;
    std::vector<Group> groups;
    std::vector<std::size_t> group_of;  // [term]
    std::size_t max_delay = 0;          // of the output factors
    int max_power = 0;
  };
  Prepared Prepare(const std::vector<SemTerm>& terms) const {
    Prepared p;
    Prepare(terms, &p);
    return p;
  }
  // The same into *out, reusing its buffers' capacity (a refinement per iteration then touches
  // no fresh pages: rows x m doubles, megabytes on long records).
  void Prepare(const std::vector<SemTerm>& terms, Prepared* out) const {
    Prepared& p = *out;
    p.m = terms.size();
    p.slots.clear();
    p.groups.clear();
    p.group_of.clear();
    p.max_delay = 0;
    p.max_power = 0;
    const std::size_t rows = rec_.y.size();
    p.input.resize(rows * p.m);
    std::vector<double> in;  // the term's input part, every row
    for (std::size_t i = 0; i < p.m; ++i) {
      const SemTerm& t = terms[i];
      in.assign(rows, 1.0);
      std::vector<std::pair<std::size_t, int>> sig;
      for (const auto& f : t.factors) {
        const auto& reg = spec_.regressors[static_cast<std::size_t>(f.regressor)];
        const auto& x = rec_.input[static_cast<std::size_t>(f.regressor)];
        const auto d = static_cast<std::size_t>(f.delay);
        if (x.empty()) {
          std::size_t s = 0;
          while (s < p.slots.size() &&
                 !(p.slots[s].transform == reg.transform && p.slots[s].exponent == reg.exponent &&
                   p.slots[s].delay == d)) {
            ++s;
          }
          if (s == p.slots.size()) p.slots.push_back({reg.transform, reg.exponent, d, 0});
          p.slots[s].max_power = std::max(p.slots[s].max_power, f.power);
          p.max_delay = std::max(p.max_delay, d);
          p.max_power = std::max(p.max_power, f.power);
          sig.emplace_back(s, f.power);
          continue;
        }
        for (std::size_t k = d; k < rows; ++k) in[k] *= IntPow(x[k - d], f.power);
      }
      for (std::size_t k = 0; k < rows; ++k) p.input[k * p.m + i] = in[k];
      std::sort(sig.begin(), sig.end());
      std::size_t g = 0;
      while (g < p.groups.size() && p.groups[g].factors != sig) ++g;
      if (g == p.groups.size()) p.groups.push_back({sig, {}});
      p.groups[g].terms.push_back(i);
      p.group_of.push_back(g);
    }
  }

  // FreeRun's buffers, reused across runs: the output history (measured before the run's first
  // row, simulated from it) and the groups' coefficient signals.
  struct Scratch {
    std::vector<double> ys, c;
  };

  // Weighted squared free-run error of a prepared structure over rows [a, b), seeded by the
  // measured output before a; +inf when the run leaves |y| <= divergence_limit or is not
  // finite. residual (optional) receives y - ysim. sens (optional; the caller's b - a rows of
  // m, row-major) receives the sensitivities d ysim_k / d theta_j for k in [a, b). The measured
  // output before a does not depend on theta; after it, by the chain rule through the output
  // factors,
  //   s_j(k) = phi_j(k) + sum_d (d ysim_k / d ysim_{k-d}) s_j(k-d).
  // The cost and residual do not depend on whether sens is asked for.
  double FreeRun(const Prepared& p, const Eigen::VectorXd& theta, std::size_t a, std::size_t b,
                 Scratch& scratch, std::vector<double>* residual, double* sens = nullptr) const {
    std::vector<double>& ys = scratch.ys;
    ys.assign(rec_.y.begin(), rec_.y.begin() + static_cast<std::ptrdiff_t>(b));
    const std::size_t m = p.m, n = b - a, ng = p.groups.size();
    const std::size_t ns = p.slots.size(), np = static_cast<std::size_t>(p.max_power) + 1;
    // c_g(k) per group, [(k - a) * ng + g]: the group's terms' input parts, in order of terms
    std::vector<double>& c = scratch.c;
    c.resize(ng * n);
    for (std::size_t g = 0; g < ng; ++g) {
      const auto& ts = p.groups[g].terms;
      for (std::size_t k = 0; k < n; ++k) {
        const double* in = p.input.data() + (a + k) * m;
        double v = 0.0;
        for (std::size_t i : ts) v += theta(static_cast<Eigen::Index>(i)) * in[i];
        c[k * ng + g] = v;
      }
    }
    std::vector<double> pw(ns * np), sl(ns), gv(ng), slope(p.max_delay + 1);
    double cost = 0.0;
    for (std::size_t k = a; k < b; ++k) {
      for (std::size_t s = 0; s < ns; ++s) {  // x_s^0 ... x_s^max_power and d x_s / d y
        const Slot& sd = p.slots[s];
        const double yd = ys[k - sd.delay];
        const double x = sd.transform == Transform::kIdentity
                             ? yd
                             : ApplyTransform(sd.transform, sd.exponent, yd);
        double* ps = pw.data() + s * np;
        ps[0] = 1.0;
        for (int q = 1; q <= sd.max_power; ++q) ps[q] = ps[q - 1] * x;
        if (sens != nullptr) sl[s] = TransformSlope(sd.transform, sd.exponent, yd);
      }
      std::fill(slope.begin(), slope.end(), 0.0);
      double v = 0.0;
      for (std::size_t g = 0; g < ng; ++g) {
        const auto& fs = p.groups[g].factors;
        const double cg = c[(k - a) * ng + g];
        double gk = 1.0;
        for (const auto& [s, q] : fs) gk *= pw[s * np + static_cast<std::size_t>(q)];
        v += cg * gk;
        if (sens == nullptr) continue;
        gv[g] = gk;
        for (std::size_t f = 0; f < fs.size(); ++f) {  // product rule over the factors
          const auto [s, q] = fs[f];
          double d = cg * q * pw[s * np + static_cast<std::size_t>(q - 1)] * sl[s];
          for (std::size_t r = 0; r < fs.size(); ++r) {
            if (r != f) d *= pw[fs[r].first * np + static_cast<std::size_t>(fs[r].second)];
          }
          slope[p.slots[s].delay] += d;
        }
      }
      if (!(std::fabs(v) <= spec_.divergence_limit)) return kInf;
      ys[k] = v;  // the simulated output feeds back
      const double e = rec_.y[k] - v;
      cost += rec_.w[k] * e * e;
      if (residual != nullptr) residual->push_back(e);
      if (sens == nullptr) continue;
      double* sk = sens + (k - a) * m;
      const double* in = p.input.data() + k * m;
      for (std::size_t j = 0; j < m; ++j) sk[j] = in[j] * gv[p.group_of[j]];
      for (std::size_t d = 1; d <= p.max_delay && d <= k - a; ++d) {
        if (slope[d] == 0.0) continue;
        const double* sp = sk - d * m;
        for (std::size_t j = 0; j < m; ++j) sk[j] += slope[d] * sp[j];
      }
    }
    return std::isfinite(cost) ? cost : kInf;
  }

 private:
  const SemSpec& spec_;
  Record rec_;
};

// RefineFreeRun's buffers (internal.hpp): the prepared structure per record, the free run's
// scratch, and the residual and Jacobian of the current and the trial coefficients.
struct RefineWorkspace {
  std::vector<Evaluator::Prepared> prepared;
  Evaluator::Scratch run;
  std::vector<double> e;
  std::vector<double> r[2], jac[2];  // [current / trial]: rows, rows x m (row-major)
};

}  // namespace mrd::host::internal
