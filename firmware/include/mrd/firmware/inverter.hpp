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
// zero residual. Choice: among the admissible roots, the one nearest the previous command;
// when none is admissible, the candidate (a bound or an interior extremum) whose force is
// closest to the demand — with a monotone model that is the bound on the demand's side.
// Ties (e.g. E has no effect in this state) go to the candidate nearest the previous command,
// which is itself a candidate: a flat polynomial holds the previous command.
//
// Scalar type T (real.hpp): the model is rounded to T at Configure, the polynomial, its roots
// and the tolerances (from T's epsilon) are in T. Inverter is the firmware's (T = Real).

#include <array>
#include <cstdint>

#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/real.hpp"

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

  struct Solution {
    T E = T(0);              // command [V], in [e_min, e_max]
    T force = T(0);          // model force at E [N]
    bool reachable = false;  // true when force equals the demand (a root was found)
  };

  // Binds the model of a validated table and the range [e_min, e_max] of the table.
  // kNotInvertible when the input enters at delay 0 through a transform other than identity
  // or low-pass (not affine in E(k)), with a total degree above 4 in one term, or not at all.
  // Not real-time (start-up).
  Error Configure(const CoefficientTable& table);
  // Narrows the admissible range [V] (e.g. the configured E_max); must lie within the
  // table's range. Returns kOutOfRange otherwise (range unchanged). Not real-time.
  Error SetRange(double e_min, double e_max);

  // Polynomial coefficients a_0 ... a_4 of the normalised output in the normalised command,
  // for a history prepared by ModelRuntime::Begin on the same table (the command slot is not
  // read; low-pass poles come from the history). Real-time safe.
  std::array<T, kMaxInputDegree + 1> Polynomial(const BasicRegressorHistory<T>& h) const;
  // Command whose model force is the demand f_demand [N], given the previous command
  // E_previous [V]. Real-time safe, bounded work.
  Solution Solve(const BasicRegressorHistory<T>& h, T f_demand, T E_previous) const;

  T e_min() const { return e_min_; }
  T e_max() const { return e_max_; }
  int degree() const { return degree_; }

 private:
  BasicModel<T> model_;
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
