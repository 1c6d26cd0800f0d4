#include "mrd/firmware/inverter.hpp"

#include <cmath>
#include <limits>
#include <utility>

namespace mrd::firmware {
namespace {

template <class T>
using Coeffs = std::array<T, kMaxInputDegree + 1>;

template <class T>
T Horner(const Coeffs<T>& a, int n, T x) {
  T p = a[static_cast<std::size_t>(n)];
  for (int j = n - 1; j >= 0; --j) p = p * x + a[static_cast<std::size_t>(j)];
  return p;
}

template <class T>
T HornerDerivative(const Coeffs<T>& a, int n, T x) {
  T d = T(0);
  for (int j = n; j >= 1; --j) d = d * x + static_cast<T>(j) * a[static_cast<std::size_t>(j)];
  return d;
}

// Root of p in [lo, hi] where p(lo) and p(hi) have opposite signs and p is monotone:
// Newton steps, replaced by bisection when they leave the bracket. At most kMaxIterations.
template <class T>
T BracketedRoot(const Coeffs<T>& a, int n, T lo, T hi, T p_lo) {
  constexpr T kHalf = T(0.5);
  constexpr T kTol = T(4) * std::numeric_limits<T>::epsilon();
  T x = kHalf * (lo + hi);
  for (int it = 0; it < BasicInverter<T>::kMaxIterations; ++it) {
    const T p = Horner(a, n, x);
    if (p == T(0)) return x;
    if ((p < T(0)) == (p_lo < T(0))) {
      lo = x;
    } else {
      hi = x;
    }
    const T d = HornerDerivative(a, n, x);
    T next = d != T(0) ? x - p / d : kHalf * (lo + hi);
    if (!(next > lo && next < hi)) next = kHalf * (lo + hi);
    if (std::fabs(next - x) <= kTol * std::fabs(x) ||
        hi - lo <= kTol * (std::fabs(lo) + std::fabs(hi))) {
      return next;
    }
    x = next;
  }
  return x;
}

// v == 0 (no dissipative direction): among the roots of a = y - y_d, the bounds and y's
// interior extrema, the least residual wins; among those within tol of it, the lowest e.
// NaN when no residual is finite (a non-finite state).
template <class T>
T LowestNearest(const Coeffs<T>& a, int n, const BasicPolyRoots<T>& r, T lo, T hi, T tol,
                bool* reachable) {
  std::array<T, 2 * kMaxInputDegree + 1> cand{};
  std::array<T, 2 * kMaxInputDegree + 1> res{};
  std::size_t count = 0;
  const auto add = [&](T e, bool is_root) {
    cand[count] = e;
    res[count] = is_root ? T(0) : std::fabs(Horner(a, n, e));
    if (res[count] <= tol) res[count] = T(0);
    ++count;
  };
  for (int i = 0; i < r.num_roots; ++i) add(r.roots[static_cast<std::size_t>(i)], true);
  add(lo, false);
  add(hi, false);
  for (int i = 0; i < r.num_critical; ++i) add(r.critical[static_cast<std::size_t>(i)], false);
  T least = std::numeric_limits<T>::infinity();
  for (std::size_t i = 0; i < count; ++i) least = std::fmin(least, res[i]);  // NaN skipped
  if (!std::isfinite(least)) return std::numeric_limits<T>::quiet_NaN();
  T best = hi;
  for (std::size_t i = 0; i < count; ++i) {
    if (res[i] <= least + tol && cand[i] < best) best = cand[i];
  }
  *reachable = least == T(0);
  return best;
}

// v != 0, a dissipative demand u = s y_d > 0 (s = sign(v)): on g(e) = max over e' <= e of
// z(e') = s y(e'), the force the damper can be relied on to give at e or below (raising E
// never lowers a semi-active damper's force; a model's dip is not used), the lowest e whose
// g is nearest u: lo when u <= z(lo); the first crossing of u (the least root of y - y_d,
// roots ascending) when z(lo) < u < max z; else the first e where z reaches its maximum.
// NaN for a non-finite state.
template <class T>
T LowestOnRisingEnvelope(const Coeffs<T>& y, int n, const BasicPolyRoots<T>& r, T lo, T hi, T s,
                         T u, T tol, bool* reachable) {
  const T z_lo = s * Horner(y, n, lo);
  if (!std::isfinite(z_lo) || !std::isfinite(u)) return std::numeric_limits<T>::quiet_NaN();
  if (u <= z_lo + tol) {
    *reachable = u >= z_lo - tol;
    return lo;
  }
  // The maximum of z over the bounds and the extrema (ascending), and where it is first hit.
  T top = z_lo;
  T top_e = lo;
  std::array<T, kMaxInputDegree + 1> e_at{};
  std::array<T, kMaxInputDegree + 1> z_at{};
  std::size_t count = 0;
  for (int i = 0; i < r.num_critical; ++i) {
    e_at[count] = r.critical[static_cast<std::size_t>(i)];
    z_at[count++] = s * Horner(y, n, r.critical[static_cast<std::size_t>(i)]);
  }
  e_at[count] = hi;
  z_at[count++] = s * Horner(y, n, hi);
  for (std::size_t i = 0; i < count; ++i) {
    if (!std::isfinite(z_at[i])) return std::numeric_limits<T>::quiet_NaN();
    top = std::fmax(top, z_at[i]);
  }
  if (u < top - tol && r.num_roots > 0) {  // the first crossing (z(lo) < u < top)
    *reachable = true;
    return r.roots[0];
  }
  *reachable = u <= top + tol;
  if (z_lo >= top - tol) return lo;
  for (std::size_t i = 0; i < count; ++i) {
    if (z_at[i] >= top - tol) {
      top_e = e_at[i];
      break;
    }
  }
  return top_e;
}

}  // namespace

template <class T>
BasicPolyRoots<T> RealRootsInInterval(const Coeffs<T>& a, int n, std::type_identity_t<T> lo,
                                      std::type_identity_t<T> hi) {
  BasicPolyRoots<T> out;
  while (n > 0 && a[static_cast<std::size_t>(n)] == T(0)) --n;
  if (n <= 0 || !(lo <= hi)) return out;
  if (n == 1) {
    const T x = -a[0] / a[1];
    if (x >= lo && x <= hi) out.roots[out.num_roots++] = x;
    return out;
  }
  Coeffs<T> d{};
  for (int j = 1; j <= n; ++j) {
    d[static_cast<std::size_t>(j - 1)] = static_cast<T>(j) * a[static_cast<std::size_t>(j)];
  }
  const BasicPolyRoots<T> dr = RealRootsInInterval<T>(d, n - 1, lo, hi);
  out.critical = dr.roots;
  out.num_critical = dr.num_roots;
  // Monotone segments between lo, the critical points and hi.
  T x0 = lo;
  T p0 = Horner(a, n, lo);
  if (p0 == T(0)) out.roots[out.num_roots++] = lo;
  for (int s = 0; s <= dr.num_roots; ++s) {
    const T x1 = s < dr.num_roots ? dr.roots[static_cast<std::size_t>(s)] : hi;
    if (x1 <= x0 && s > 0) continue;  // repeated critical point
    const T p1 = Horner(a, n, x1);
    if (p1 == T(0)) {
      if (out.num_roots == 0 || out.roots[static_cast<std::size_t>(out.num_roots - 1)] != x1) {
        if (out.num_roots < kMaxInputDegree) out.roots[out.num_roots++] = x1;
      }
    } else if (p0 != T(0) && (p0 < T(0)) != (p1 < T(0))) {
      if (out.num_roots < kMaxInputDegree) {
        out.roots[out.num_roots++] = BracketedRoot(a, n, x0, x1, p0);
      }
    }
    x0 = x1;
    p0 = p1;
  }
  return out;
}

template <class T>
Error BasicInverter<T>::Configure(const CoefficientTable& table) {
  Error e = Error::kOk;
  auto shared = BasicSharedModel<T>::Load(table, &e);
  if (e != Error::kOk) return e;
  return Configure(std::move(shared));
}

template <class T>
Error BasicInverter<T>::Configure(std::shared_ptr<const BasicSharedModel<T>> shared) {
  const CoefficientTable& table = shared->table();
  const BasicModel<T>& m = shared->model();
  if (CheckInversion(table).problem != InversionProblem::kNone) return Error::kNotInvertible;
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
  shared_ = std::move(shared);
  model_ = &shared_->model();
  term_degree_ = degree;
  has_low_pass_ = low_pass;
  is_input_ = is_input;
  input_scale_ = m.scales[table.input_channel];
  output_scale_ = m.scales[m.output_channel];
  table_e_min_ = table.e_min;
  table_e_max_ = table.e_max;
  e_min_ = static_cast<T>(table.e_min);
  e_max_ = static_cast<T>(table.e_max);
  degree_ = max_degree;
  return Error::kOk;
}

template <class T>
Error BasicInverter<T>::SetRange(double e_min, double e_max) {
  if (!std::isfinite(e_min) || !std::isfinite(e_max)) return Error::kNonFinite;
  if (!(e_min < e_max) || e_min < table_e_min_ || e_max > table_e_max_) return Error::kOutOfRange;
  e_min_ = static_cast<T>(e_min);
  e_max_ = static_cast<T>(e_max);
  return Error::kOk;
}

template <class T>
std::array<T, kMaxInputDegree + 1> BasicInverter<T>::Polynomial(
    const BasicRegressorHistory<T>& h) const {
  Coeffs<T> a{};
  if (model_ == nullptr) return a;  // not configured
  for (std::size_t i = 0; i < model_->num_terms; ++i) {
    const Term& term = model_->terms[i];
    T v = model_->coefficients[i];  // theta_i * (the term's other factors)
    for (std::size_t f = 0; f < term.num_factors; ++f) {
      if (is_input_[i][f]) continue;
      const T base = h.value(term.factors[f].regressor, term.factors[f].delay);
      for (std::uint8_t p = 0; p < term.factors[f].power; ++p) v *= base;
    }
    if (!has_low_pass_[i]) {  // only identity E(k) factors: v * e^degree
      a[term_degree_[i]] += v;
      continue;
    }
    // Expand v * prod (alpha + beta e)^p with LowPassStep(q, r(k-1), e) = alpha + beta e:
    // alpha = q * r(k-1), beta = 1 - q; identity factors have q = 0 (alpha 0, beta 1).
    Coeffs<T> t{};
    t[0] = v;
    std::size_t degree = 0;
    for (std::size_t f = 0; f < term.num_factors; ++f) {
      if (!is_input_[i][f]) continue;
      const Factor& fac = term.factors[f];
      const T pole = h.low_pass_pole(fac.regressor);
      const T alpha = pole * h.value(fac.regressor, 1);
      const T beta = T(1) - pole;
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

template <class T>
typename BasicInverter<T>::Solution BasicInverter<T>::Solve(const BasicRegressorHistory<T>& h,
                                                            T f_demand, T velocity) const {
  Coeffs<T> a = Polynomial(h);
  const T y_demand = Normalise(output_scale_, f_demand);
  const T lo = Normalise(input_scale_, e_min_);
  const T hi = Normalise(input_scale_, e_max_);
  const Coeffs<T> y = a;  // y(e) before shifting by the demand
  a[0] -= y_demand;
  // A zero demand, or one of the sign opposite to v (a semi-active damper cannot push): the
  // softest setting whatever the model says; only the critical points are needed (monotony).
  const bool passive = f_demand == T(0) || f_demand * velocity < T(0);
  const BasicPolyRoots<T> r = RealRootsInInterval<T>(passive ? y : a, degree_, lo, hi);

  // Residual tolerance: a few ulps of the terms' magnitudes at the bounds.
  T magnitude = std::fabs(y_demand);
  const T emax = std::fmax(std::fabs(lo), std::fabs(hi));
  T power = T(1);
  for (std::size_t j = 0; j <= static_cast<std::size_t>(degree_); ++j) {
    magnitude += std::fabs(y[j]) * power;
    power *= emax;
  }
  const T tol = T(64) * std::numeric_limits<T>::epsilon() * magnitude;

  // Monotony at this state: no interior extremum beyond the forces at the bounds (by more
  // than kMonotoneSlack of the force span between them, or the residual tolerance).
  const T y_lo = Horner(y, degree_, lo);
  const T y_hi = Horner(y, degree_, hi);
  const T span = std::fabs(y_hi - y_lo);
  T y_top = std::fmax(y_lo, y_hi);
  T y_bottom = std::fmin(y_lo, y_hi);
  for (int i = 0; i < r.num_critical; ++i) {
    const T yc = Horner(y, degree_, r.critical[static_cast<std::size_t>(i)]);
    y_top = std::fmax(y_top, yc);
    y_bottom = std::fmin(y_bottom, yc);
  }
  const T slack = std::fmax(T(kMonotoneSlack) * span, tol);
  const bool monotone = !(y_top - y_bottom > span + slack);

  Solution s;
  s.passive = passive;
  s.monotone = monotone;
  T best_e = lo;
  if (!passive) {
    bool reachable = false;
    const T e = velocity == T(0) ? LowestNearest(a, degree_, r, lo, hi, tol, &reachable)
                                 : LowestOnRisingEnvelope(
                                       y, degree_, r, lo, hi, velocity > T(0) ? T(1) : T(-1),
                                       velocity > T(0) ? y_demand : -y_demand, tol, &reachable);
    if (std::isfinite(e)) {  // else a non-finite state: the lowest command
      best_e = e;
      s.reachable = reachable;
    }
  }
  s.E = std::fmin(std::fmax(Denormalise(input_scale_, best_e), e_min_), e_max_);
  s.force = Denormalise(output_scale_, Horner(y, degree_, best_e));
  if (passive) s.reachable = std::fabs(Horner(a, degree_, best_e)) <= tol;
  return s;
}

template BasicPolyRoots<double> RealRootsInInterval<double>(const Coeffs<double>&, int, double,
                                                            double);
template BasicPolyRoots<float> RealRootsInInterval<float>(const Coeffs<float>&, int, float, float);
template class BasicInverter<double>;
template class BasicInverter<float>;

}  // namespace mrd::firmware
