// Output-error refinement of a structure's coefficients (host/src/sem/internal.hpp):
// Levenberg-Marquardt on the free-run cost J, started from the one-step least squares. Least
// squares on the one-step regression is biased when the noise enters the output (the measured
// output in the regressors is noisy); minimising J itself removes that bias, so a spurious term no
// longer lowers J by compensating it.
#include <Eigen/Dense>
#include <cmath>
#include <limits>

#include "sem/estimate/evaluator.hpp"
#include "sem/internal.hpp"

namespace mrd::host::internal {
namespace {

constexpr int kMaxSteps = 30;      // LM steps (accepted or not)
constexpr double kRelStop = 1e-6;  // stop when an accepted step lowers J by less
// Levenberg-Marquardt damping, relative to the diagonal of J^T J (Marquardt's scaling, so
// dimensionless): lambda * diag is added to the diagonal; start small (the least-squares start
// is close, Gauss-Newton converges in a few steps); give up when a step that small still fails.
constexpr double kLambda0 = 1e-4;
constexpr double kLambdaMax = 1e12;

// Buffers of Residual, reused across the steps.
struct Work {
  Evaluator::Scratch run;
  std::vector<double> e;
};

// Weighted free-run residual r_k = sqrt(w_k) (y_k - ysim_k) over every scored row of every
// record, and its Jacobian d r / d theta = -sqrt(w_k) d ysim_k / d theta from the sensitivity
// recursion (exact, one pass for all columns); false when a run diverges.
bool Residual(const std::vector<Evaluator>& ev, const std::vector<Evaluator::Prepared>& prepared,
              const Eigen::VectorXd& theta, Work& w, Eigen::VectorXd* r, Jacobian* jac) {
  const auto m = static_cast<std::size_t>(theta.size());
  Eigen::Index rows = 0;
  for (const Evaluator& e : ev) {
    rows += static_cast<Eigen::Index>(e.record().y.size() - e.record().first);
  }
  r->resize(rows);
  jac->resize(rows, theta.size());
  Eigen::Index row = 0;
  for (std::size_t i = 0; i < ev.size(); ++i) {
    const Record& rec = ev[i].record();
    w.e.clear();
    const double cost = ev[i].FreeRun(prepared[i], theta, rec.first, rec.y.size(), w.run, &w.e,
                                      jac->data() + row * static_cast<Eigen::Index>(m));
    if (!std::isfinite(cost)) {
      return false;
    }
    for (std::size_t k = 0; k < w.e.size(); ++k, ++row) {
      const double sw = std::sqrt(rec.w[rec.first + k]);
      (*r)(row) = sw * w.e[k];
      double* jr = jac->data() + row * static_cast<Eigen::Index>(m);
      for (std::size_t j = 0; j < m; ++j) jr[j] *= -sw;  // d ysim / d theta -> d r / d theta
    }
  }
  return true;
}

}  // namespace

double RefineFreeRun(const std::vector<Evaluator>& ev, const std::vector<SemTerm>& terms,
                     std::vector<double>* coefficients, Jacobian* jacobian,
                     Eigen::VectorXd* residual) {
  const auto m = static_cast<Eigen::Index>(terms.size());
  Eigen::VectorXd theta(m);
  for (Eigen::Index i = 0; i < m; ++i) theta(i) = (*coefficients)[static_cast<std::size_t>(i)];
  std::vector<Evaluator::Prepared> prepared;
  for (const Evaluator& e : ev) prepared.push_back(e.Prepare(terms));
  Work work;
  Eigen::VectorXd r, rt;
  Jacobian jac, jt;
  if (!Residual(ev, prepared, theta, work, &r, &jac)) return kInf;
  double j = r.squaredNorm();
  Eigen::MatrixXd a;  // J^T J
  Eigen::VectorXd g;  // J^T r
  auto normal_equations = [&]() {
    Eigen::MatrixXd low = Eigen::MatrixXd::Zero(m, m);  // lower half only: half the work
    low.selfadjointView<Eigen::Lower>().rankUpdate(jac.transpose());
    a = low.selfadjointView<Eigen::Lower>();
    g.noalias() = jac.transpose() * r;
  };
  normal_equations();
  double lambda = kLambda0;
  for (int step = 0; step < kMaxSteps && m > 0; ++step) {
    Eigen::MatrixXd damped = a;
    damped.diagonal() += lambda * a.diagonal().cwiseMax(1e-12 * a.diagonal().maxCoeff());
    const Eigen::VectorXd delta = damped.ldlt().solve(-g);
    if (!delta.allFinite()) break;
    // Converged when the linearised residual promises less than kRelStop of J (at the optimum
    // already, e.g. a structure without output terms, whose free run is its one-step fit).
    const double predicted = -(2.0 * g.dot(delta) + delta.dot(a * delta));
    if (!(predicted > kRelStop * j)) break;
    const Eigen::VectorXd cand = theta + delta;
    if (Residual(ev, prepared, cand, work, &rt, &jt) && rt.squaredNorm() < j) {
      const double jn = rt.squaredNorm();
      const bool done = j - jn < kRelStop * j;
      theta = cand;
      r.swap(rt);
      jac.swap(jt);
      j = jn;
      if (done) break;
      normal_equations();
      lambda *= 0.2;
    } else {
      lambda *= 10.0;
      if (lambda > kLambdaMax) break;
    }
  }
  for (Eigen::Index i = 0; i < m; ++i) (*coefficients)[static_cast<std::size_t>(i)] = theta(i);
  if (jacobian != nullptr) *jacobian = jac;
  if (residual != nullptr) *residual = r;
  return j;
}

}  // namespace mrd::host::internal
