#include "mrd/firmware/inverter.hpp"

#include <cmath>
#include <limits>

namespace mrd::firmware {
namespace {

using Coeffs = std::array<double, kMaxInputDegree + 1>;

double Horner(const Coeffs& a, int n, double x) {
  double p = a[static_cast<std::size_t>(n)];
  for (int j = n - 1; j >= 0; --j) p = p * x + a[static_cast<std::size_t>(j)];
  return p;
}

double HornerDerivative(const Coeffs& a, int n, double x) {
  double d = 0.0;
  for (int j = n; j >= 1; --j) d = d * x + j * a[static_cast<std::size_t>(j)];
  return d;
}

// Root of p in [lo, hi] where p(lo) and p(hi) have opposite signs and p is monotone:
// Newton steps, replaced by bisection when they leave the bracket. At most kMaxIterations.
double BracketedRoot(const Coeffs& a, int n, double lo, double hi, double p_lo) {
  double x = 0.5 * (lo + hi);
  for (int it = 0; it < Inverter::kMaxIterations; ++it) {
    const double p = Horner(a, n, x);
    if (p == 0.0) return x;
    if ((p < 0.0) == (p_lo < 0.0)) {
      lo = x;
    } else {
      hi = x;
    }
    const double d = HornerDerivative(a, n, x);
    double next = d != 0.0 ? x - p / d : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::fabs(next - x) <= 4.0 * std::numeric_limits<double>::epsilon() * std::fabs(x) ||
        hi - lo <= 4.0 * std::numeric_limits<double>::epsilon() * (std::fabs(lo) + std::fabs(hi))) {
      return next;
    }
    x = next;
  }
  return x;
}

}  // namespace

PolyRoots RealRootsInInterval(const Coeffs& a, int n, double lo, double hi) {
  PolyRoots out;
  while (n > 0 && a[static_cast<std::size_t>(n)] == 0.0) --n;
  if (n <= 0 || !(lo <= hi)) return out;
  if (n == 1) {
    const double x = -a[0] / a[1];
    if (x >= lo && x <= hi) out.roots[out.num_roots++] = x;
    return out;
  }
  Coeffs d{};
  for (int j = 1; j <= n; ++j) {
    d[static_cast<std::size_t>(j - 1)] = j * a[static_cast<std::size_t>(j)];
  }
  const PolyRoots dr = RealRootsInInterval(d, n - 1, lo, hi);
  out.critical = dr.roots;
  out.num_critical = dr.num_roots;
  // Monotone segments between lo, the critical points and hi.
  double x0 = lo;
  double p0 = Horner(a, n, lo);
  if (p0 == 0.0) out.roots[out.num_roots++] = lo;
  for (int s = 0; s <= dr.num_roots; ++s) {
    const double x1 = s < dr.num_roots ? dr.roots[static_cast<std::size_t>(s)] : hi;
    if (x1 <= x0 && s > 0) continue;  // repeated critical point
    const double p1 = Horner(a, n, x1);
    if (p1 == 0.0) {
      if (out.num_roots == 0 || out.roots[static_cast<std::size_t>(out.num_roots - 1)] != x1) {
        if (out.num_roots < kMaxInputDegree) out.roots[out.num_roots++] = x1;
      }
    } else if (p0 != 0.0 && (p0 < 0.0) != (p1 < 0.0)) {
      if (out.num_roots < kMaxInputDegree) {
        out.roots[out.num_roots++] = BracketedRoot(a, n, x0, x1, p0);
      }
    }
    x0 = x1;
    p0 = p1;
  }
  return out;
}

Error Inverter::Configure(const CoefficientTable& table) {
  const Error e = table.Validate();
  if (e != Error::kOk) return e;
  if (CheckInversion(table).problem != InversionProblem::kNone) return Error::kNotInvertible;
  const Model& m = table.model;
  std::array<std::uint8_t, kMaxTerms> degree{};
  std::array<std::array<bool, kMaxFactors>, kMaxTerms> is_input{};
  std::array<bool, kMaxTerms> low_pass{};
  int max_degree = 0;
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    int d = 0;
    for (std::size_t f = 0; f < m.terms[i].num_factors; ++f) {
      const Factor& fac = m.terms[i].factors[f];
      if (!IsDirectInput(table, fac)) continue;  // CheckInversion: identity or low-pass
      is_input[i][f] = true;
      low_pass[i] = low_pass[i] || m.regressors[fac.regressor].transform == Transform::kLowPass;
      d += fac.power;
    }
    degree[i] = static_cast<std::uint8_t>(d);
    max_degree = d > max_degree ? d : max_degree;
  }
  if (max_degree == 0) return Error::kNotInvertible;  // E(k) does not enter the model
  model_ = m;
  term_degree_ = degree;
  has_low_pass_ = low_pass;
  is_input_ = is_input;
  input_scale_ = m.scales[table.input_channel];
  output_scale_ = m.scales[m.output_channel];
  table_e_min_ = e_min_ = table.e_min;
  table_e_max_ = e_max_ = table.e_max;
  degree_ = max_degree;
  return Error::kOk;
}

Error Inverter::SetRange(double e_min, double e_max) {
  if (!std::isfinite(e_min) || !std::isfinite(e_max)) return Error::kNonFinite;
  if (!(e_min < e_max) || e_min < table_e_min_ || e_max > table_e_max_) return Error::kOutOfRange;
  e_min_ = e_min;
  e_max_ = e_max;
  return Error::kOk;
}

std::array<double, kMaxInputDegree + 1> Inverter::Polynomial(const RegressorHistory& h) const {
  Coeffs a{};
  for (std::size_t i = 0; i < model_.num_terms; ++i) {
    const Term& term = model_.terms[i];
    double v = model_.coefficients[i];  // theta_i * (the term's other factors)
    for (std::size_t f = 0; f < term.num_factors; ++f) {
      if (is_input_[i][f]) continue;
      const double base = h.value(term.factors[f].regressor, term.factors[f].delay);
      for (std::uint8_t p = 0; p < term.factors[f].power; ++p) v *= base;
    }
    if (!has_low_pass_[i]) {  // only identity E(k) factors: v * e^degree
      a[term_degree_[i]] += v;
      continue;
    }
    // Expand v * prod (alpha + beta e)^p with LowPassStep(q, r(k-1), e) = alpha + beta e:
    // alpha = q * r(k-1), beta = 1 - q; identity factors have q = 0 (alpha 0, beta 1).
    Coeffs t{};
    t[0] = v;
    std::size_t degree = 0;
    for (std::size_t f = 0; f < term.num_factors; ++f) {
      if (!is_input_[i][f]) continue;
      const Factor& fac = term.factors[f];
      const double pole = h.low_pass_pole(fac.regressor);
      const double alpha = pole * h.value(fac.regressor, 1);
      const double beta = 1.0 - pole;
      for (std::uint8_t p = 0; p < fac.power; ++p) {
        ++degree;
        t[degree] = beta * t[degree - 1];
        for (std::size_t j = degree - 1; j >= 1; --j) t[j] = alpha * t[j] + beta * t[j - 1];
        t[0] *= alpha;
      }
    }
    for (std::size_t j = 0; j <= degree; ++j) a[j] += t[j];
  }
  return a;
}

Inverter::Solution Inverter::Solve(const RegressorHistory& h, double f_demand,
                                   double E_previous) const {
  Coeffs a = Polynomial(h);
  const double y_demand = Normalise(output_scale_, f_demand);
  const double lo = Normalise(input_scale_, e_min_);
  const double hi = Normalise(input_scale_, e_max_);
  const double prev = Normalise(input_scale_, E_previous);
  const Coeffs y = a;  // y(e) before shifting by the demand
  a[0] -= y_demand;
  const PolyRoots r = RealRootsInInterval(a, degree_, lo, hi);

  // Residual tolerance: a few ulps of the terms' magnitudes at the bounds.
  double magnitude = std::fabs(y_demand);
  const double emax = std::fmax(std::fabs(lo), std::fabs(hi));
  double power = 1.0;
  for (std::size_t j = 0; j <= static_cast<std::size_t>(degree_); ++j) {
    magnitude += std::fabs(y[j]) * power;
    power *= emax;
  }
  const double tol = 64.0 * std::numeric_limits<double>::epsilon() * magnitude;

  double best_e = std::fmin(std::fmax(prev, lo), hi);
  double best_residual = std::numeric_limits<double>::infinity();
  double best_distance = std::numeric_limits<double>::infinity();
  bool reachable = false;
  auto consider = [&](double e, bool is_root) {
    const double residual = is_root ? 0.0 : std::fabs(Horner(a, degree_, e));
    const bool root = residual <= tol;
    const double distance = std::fabs(e - prev);
    const double score = root ? 0.0 : residual;
    if (score < best_residual || (score == best_residual && distance < best_distance)) {
      best_e = e;
      best_residual = score;
      best_distance = distance;
      reachable = root;
    }
  };
  for (int i = 0; i < r.num_roots; ++i) consider(r.roots[static_cast<std::size_t>(i)], true);
  consider(lo, false);
  consider(hi, false);
  consider(std::fmin(std::fmax(prev, lo), hi), false);  // wins only a tie (flat in E)
  for (int i = 0; i < r.num_critical; ++i) consider(r.critical[static_cast<std::size_t>(i)], false);
  if (!std::isfinite(best_residual)) best_e = lo;  // non-finite state: lowest command

  Solution s;
  s.E = std::fmin(std::fmax(Denormalise(input_scale_, best_e), e_min_), e_max_);
  s.force = Denormalise(output_scale_, Horner(y, degree_, best_e));
  s.reachable = reachable;
  return s;
}

}  // namespace mrd::firmware
