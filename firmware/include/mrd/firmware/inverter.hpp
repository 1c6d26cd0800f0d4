#pragma once
// Analytic inversion of the model in its command input (docs/design.md §7).
//
// With the history of sample k known (ModelRuntime::Begin), the normalised model output is a
// polynomial of degree n <= 4 in the normalised command e = (E - offset_E) / scale_E:
//
//   y(e) = sum_{j=0}^{n} a_j e^j,   a_j = sum over terms with E(k)-degree j of
//                                          theta_i * (product of the term's other factors)
//
// E(k) enters through identity regressors (e) or low-pass ones (a r(k-1) + (1 - a) e, affine
// in e), so each term is expanded as theta_i * (others) * prod (alpha + beta e)^p.
//
// Solve y(e) = y_d on [e_min, e_max]: real roots are isolated between the critical points of
// y (found recursively from the derivative, degree n-1 ... 1, closed form at degree 1) and
// polished by a bracketed Newton/bisection iteration of at most kMaxIterations steps, so
// the work per call is bounded. Repeated (touching) roots appear as critical points with a
// zero residual.
//
// Choice (a semi-active damper: it can only dissipate, with a force of the sign of v):
// - a demand of 0 N, or of the sign opposite to v, gives E_min (passive), whatever the model
//   says (a model non-monotone in E may give less force at a stiffer setting);
// - any other demand: on the dissipative force the damper can be relied on to give at E or
//   below, g(E) = max over E' <= E of s f(E'), s = sign(v) (raising E never lowers a damper's
//   force, so a dip in the model is not used), the LOWEST E whose g is nearest the demand:
//   E_min for a demand at or below the force at E_min; the first E reaching the demand; for a
//   demand beyond every force, the first E of the largest. Never a higher E for a smaller
//   dissipative demand; with a model whose force grows with E, simply the E whose force is
//   the demand (or the bound nearest it). A state where E has no effect gives E_min.
// - v == 0 (no dissipative direction): the lowest E whose model force is nearest the demand.
// The solution says whether the model was monotone in E on [E_min, E_max] at the state (no
// interior extremum beyond the forces at the bounds by more than kMonotoneSlack of their
// difference): with a monotone model the command grows with the dissipative demand.
//
// Scalar type T (real.hpp): the model is rounded to T at Configure, the polynomial, its roots
// and the tolerances (from T's epsilon) are in T. Inverter is the firmware's (T = Real).

#include <array>
#include <cstdint>
#include <memory>

#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/real.hpp"
#include "mrd/firmware/shared_model.hpp"

namespace mrd::firmware {

using mrd::kMaxInputDegree;  // common/table.hpp

// Real roots of p(x) = sum_{j<=n} a[j] x^j in [lo, hi], ascending, at most n of them, and
// p's critical points in [lo, hi] (at most n - 1). Exact zero leading coefficients are
// dropped. Real-time safe, bounded work. Returns the number of roots.
template <class T>
struct BasicPolyRoots {
  std::array<T, kMaxInputDegree> roots{};
  int num_roots = 0;
  std::array<T, kMaxInputDegree> critical{};
  int num_critical = 0;
};
template <class T>
BasicPolyRoots<T> RealRootsInInterval(const std::array<T, kMaxInputDegree + 1>& a, int n,
                                      std::type_identity_t<T> lo, std::type_identity_t<T> hi);
using PolyRoots = BasicPolyRoots<Real>;

template <class T>
class BasicInverter {
 public:
  static constexpr int kMaxIterations = 60;  // per root: Newton with bisection safeguard
  // An interior extremum within this fraction of |f(E_max) - f(E_min)| beyond the bounds'
  // forces still counts as monotone (rounding, a flat top).
  static constexpr double kMonotoneSlack = 1e-3;

  struct Solution {
    T E = T(0);              // command [V], in [e_min, e_max]
    T force = T(0);          // model force at E [N]
    bool reachable = false;  // true when force equals the demand (a root was found)
    bool passive = false;    // demand 0 or of the sign opposite to v: E_min by rule
    bool monotone = true;    // the model is monotone in E on [E_min, E_max] at this state
  };

  // Binds the model of a validated table and the range [e_min, e_max] of the table.
  // kNotInvertible when the input enters at delay 0 through a transform other than identity
  // or low-pass (not affine in E(k)), with a total degree above 4 in one term, or not at all.
  // Not real-time (start-up).
  Error Configure(const CoefficientTable& table);
  // The same on a loaded model shared with other channels (shared_model.hpp; non-null): the
  // model is read from it, not copied. Not real-time (start-up).
  Error Configure(std::shared_ptr<const BasicSharedModel<T>> shared);
  // Narrows the admissible range [V] (e.g. the configured E_max); must lie within the
  // table's range. Returns kOutOfRange otherwise (range unchanged). Not real-time.
  Error SetRange(double e_min, double e_max);

  // Polynomial coefficients a_0 ... a_4 of the normalised output in the normalised command,
  // for a history prepared by ModelRuntime::Begin on the same table (the command slot is not
  // read; low-pass poles come from the history). Real-time safe.
  std::array<T, kMaxInputDegree + 1> Polynomial(const BasicRegressorHistory<T>& h) const;
  // Command for the force demand f_demand [N] at the damper velocity `velocity` [cm/s] (its
  // sign is the dissipative direction), by the choice above. Real-time safe, bounded work.
  Solution Solve(const BasicRegressorHistory<T>& h, T f_demand, T velocity) const;

  T e_min() const { return e_min_; }
  T e_max() const { return e_max_; }
  int degree() const { return degree_; }

 private:
  std::shared_ptr<const BasicSharedModel<T>> shared_;  // null before Configure
  const BasicModel<T>* model_ = nullptr;               // shared_'s, at hand
  std::array<std::uint8_t, kMaxTerms> term_degree_{};
  // Per term and factor: true when the factor is an input regressor at delay 0.
  std::array<std::array<bool, kMaxFactors>, kMaxTerms> is_input_{};
  std::array<bool, kMaxTerms> has_low_pass_{};  // term has a low-pass E(k) factor
  BasicChannelScale<T> input_scale_;
  BasicChannelScale<T> output_scale_;
  double table_e_min_ = 0.0;
  double table_e_max_ = 0.0;
  T e_min_ = T(0);
  T e_max_ = T(0);
  int degree_ = 0;
};

using Inverter = BasicInverter<Real>;

}  // namespace mrd::firmware
