#include "mrd/common/invertibility.hpp"

#include <cmath>

namespace mrd {
namespace {

template <class T>
using Coeffs = std::array<T, kMaxInputDegree + 1>;

// dy/de at e from y's coefficients a (degree <= kMaxInputDegree).
template <class T>
T Slope(const Coeffs<T>& a, T e) {
  T d = T(0);
  for (int j = kMaxInputDegree; j >= 1; --j) {
    d = d * e + static_cast<T>(j) * a[static_cast<std::size_t>(j)];
  }
  return d;
}

// True when factor f of the term is the input channel at delay 0.
template <class T>
bool IsInput(const BasicModel<T>& m, const Factor& f, std::size_t input_channel) {
  return f.delay == 0 && m.regressors[f.regressor].channel == input_channel;
}

}  // namespace

double DefaultSlopeTolerance(double output_scale, double e_min, double e_max) {
  const double span = e_max - e_min;
  if (!(span > 0.0) || !std::isfinite(span) || !std::isfinite(output_scale)) return 0.0;
  return kFlatForceShare * std::fabs(output_scale) / span;
}

template <class T>
Coeffs<T> TermInputPolynomial(const BasicModel<T>& m, const Term& term, std::size_t input_channel,
                              const BasicRegressorHistory<T>& h) {
  // v * prod over input factors of (alpha + beta e)^p: identity alpha 0, beta 1; low-pass
  // LowPassStep(q, r(k-1), e) = q r(k-1) + (1 - q) e. v: the product of the other factors.
  Coeffs<T> t{};
  t[0] = T(1);
  std::size_t degree = 0;
  for (const Factor& f : term.active()) {
    if (IsInput(m, f, input_channel)) continue;
    const T base = h.value(f.regressor, f.delay);
    for (std::uint8_t p = 0; p < f.power; ++p) t[0] *= base;
  }
  for (const Factor& f : term.active()) {
    if (!IsInput(m, f, input_channel)) continue;
    const bool low_pass = m.regressors[f.regressor].transform == Transform::kLowPass;
    const T pole = low_pass ? h.low_pass_pole(f.regressor) : T(0);
    const T alpha = low_pass ? pole * h.value(f.regressor, 1) : T(0);
    const T beta = T(1) - pole;
    for (std::uint8_t p = 0; p < f.power && degree < kMaxInputDegree; ++p) {
      ++degree;
      t[degree] = beta * t[degree - 1];
      for (std::size_t j = degree - 1; j >= 1; --j) t[j] = alpha * t[j] + beta * t[j - 1];
      t[0] *= alpha;
    }
  }
  return t;
}

template <class T>
Coeffs<T> InputPolynomial(const BasicModel<T>& m, std::size_t input_channel,
                          const BasicRegressorHistory<T>& h) {
  Coeffs<T> a{};
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    const Coeffs<T> t = TermInputPolynomial(m, m.terms[i], input_channel, h);
    for (std::size_t j = 0; j < a.size(); ++j) a[j] += m.coefficients[i] * t[j];
  }
  return a;
}

template <class T>
StateInvertibility CheckInputPolynomial(const Coeffs<T>& a, const BasicChannelScale<T>& input,
                                        const BasicChannelScale<T>& output, int velocity_sign,
                                        const InvertibilityLimits& limits) {
  const T lo = Normalise(input, static_cast<T>(limits.e_min));
  const T hi = Normalise(input, static_cast<T>(limits.e_max));
  // Candidates for the extremes of dy/de on [lo, hi]: the ends and the roots of
  // d2y/de2 = c0 + c1 e + c2 e^2 inside.
  std::array<T, 4> at{lo, hi, lo, lo};
  int n = 2;
  const T c0 = T(2) * a[2], c1 = T(6) * a[3], c2 = T(12) * a[4];
  auto inside = [&](T e) {
    if (e > lo && e < hi) at[static_cast<std::size_t>(n++)] = e;
  };
  if (c2 != T(0)) {
    const T disc = c1 * c1 - T(4) * c2 * c0;
    if (disc >= T(0)) {
      const T r = std::sqrt(disc);
      // Stable pair: q = -(c1 + sign(c1) r) / 2, roots q / c2 and c0 / q.
      const T q = T(-0.5) * (c1 + (c1 >= T(0) ? r : -r));
      inside(q / c2);
      if (q != T(0)) inside(c0 / q);
    }
  } else if (c1 != T(0)) {
    inside(-c0 / c1);
  }
  const double gain = static_cast<double>(output.scale) / static_cast<double>(input.scale);
  const double s = velocity_sign < 0 ? -1.0 : 1.0;
  StateInvertibility out;
  for (int i = 0; i < n; ++i) {
    const T e = at[static_cast<std::size_t>(i)];
    const double slope = static_cast<double>(Slope(a, e)) * gain;  // df/dE
    if (i == 0 || slope < out.min_slope) out.min_slope = slope;
    if (i == 0 || slope > out.max_slope) out.max_slope = slope;
    if (i == 0 || s * slope < out.worst_slope) {
      out.worst_slope = s * slope;
      out.worst_e = static_cast<double>(Denormalise(input, e));
    }
  }
  const double tol = limits.tolerance;
  // A non-finite slope (a diverged state) fails both.
  const bool finite = std::isfinite(out.min_slope) && std::isfinite(out.max_slope);
  out.monotone = finite && (velocity_sign == 0 || out.worst_slope >= -tol);
  out.one_to_one = finite && !(out.min_slope < -tol && out.max_slope > tol);
  return out;
}

template <class T>
StateInvertibility CheckStateInvertibility(const BasicModel<T>& m, std::size_t input_channel,
                                           const BasicRegressorHistory<T>& h, T velocity,
                                           const InvertibilityLimits& limits) {
  const int sign = velocity > T(0) ? 1 : (velocity < T(0) ? -1 : 0);
  return CheckInputPolynomial(InputPolynomial(m, input_channel, h), m.scales[input_channel],
                              m.scales[m.output_channel], sign, limits);
}

#define MRD_INSTANTIATE_INVERTIBILITY(T)                                                     \
  template Coeffs<T> TermInputPolynomial<T>(const BasicModel<T>&, const Term&, std::size_t,  \
                                            const BasicRegressorHistory<T>&);                \
  template Coeffs<T> InputPolynomial<T>(const BasicModel<T>&, std::size_t,                   \
                                        const BasicRegressorHistory<T>&);                    \
  template StateInvertibility CheckInputPolynomial<T>(                                       \
      const Coeffs<T>&, const BasicChannelScale<T>&, const BasicChannelScale<T>&, int,       \
      const InvertibilityLimits&);                                                           \
  template StateInvertibility CheckStateInvertibility<T>(const BasicModel<T>&, std::size_t,  \
                                                         const BasicRegressorHistory<T>&, T, \
                                                         const InvertibilityLimits&);
MRD_INSTANTIATE_INVERTIBILITY(double)
MRD_INSTANTIATE_INVERTIBILITY(float)
#undef MRD_INSTANTIATE_INVERTIBILITY

}  // namespace mrd
