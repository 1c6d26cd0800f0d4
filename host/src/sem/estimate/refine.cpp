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

using Rows = Eigen::Map<Eigen::VectorXd>;
using JacRows = Eigen::Map<Jacobian>;

// Weighted free-run residual r_k = sqrt(w_k) (y_k - ysim_k) over every scored row of every
// record into r (rows), and its Jacobian d r / d theta = -sqrt(w_k) d ysim_k / d theta from the
// sensitivity recursion (exact, one pass for all columns) into jac (rows x m, row-major);
// false when a run diverges.
bool Residual(const std::vector<Evaluator>& ev, const Eigen::VectorXd& theta, RefineWorkspace& w,
              double* r, double* jac) {
  const auto m = static_cast<std::size_t>(theta.size());
  std::size_t row = 0;
  for (std::size_t i = 0; i < ev.size(); ++i) {
    const Record& rec = ev[i].record();
    w.e.clear();
    const double cost =
        ev[i].FreeRun(w.prepared[i], theta, rec.first, rec.y.size(), w.run, &w.e, jac + row * m);
    if (!std::isfinite(cost)) {
      return false;
    }
    for (std::size_t k = 0; k < w.e.size(); ++k, ++row) {
      const double sw = std::sqrt(rec.w[rec.first + k]);
      r[row] = sw * w.e[k];
      double* jr = jac + row * m;
      for (std::size_t j = 0; j < m; ++j) jr[j] *= -sw;  // d ysim / d theta -> d r / d theta
    }
  }
  return true;
}

}  // namespace

double RefineFreeRun(const std::vector<Evaluator>& ev, const std::vector<SemTerm>& terms,
                     std::vector<double>* coefficients, Jacobian* jacobian,
                     Eigen::VectorXd* residual, RefineWorkspace* ws) {
  // Without a workspace: this thread's, kept between calls (a fresh one zero-fills and faults in
  // rows x m doubles twice per call, which cost more than the refinement on the selection's moves).
  thread_local RefineWorkspace local;
  RefineWorkspace& w = ws != nullptr ? *ws : local;
  const auto m = static_cast<Eigen::Index>(terms.size());
  Eigen::VectorXd theta(m);
  for (Eigen::Index i = 0; i < m; ++i) theta(i) = (*coefficients)[static_cast<std::size_t>(i)];
  w.prepared.resize(ev.size());
  Eigen::Index rows = 0;
  for (std::size_t i = 0; i < ev.size(); ++i) {
    ev[i].Prepare(terms, &w.prepared[i]);
    rows += static_cast<Eigen::Index>(ev[i].record().y.size() - ev[i].record().first);
  }
  for (int b = 0; b < 2; ++b) {  // resize keeps the capacity: no fresh pages after the first
    w.r[b].resize(static_cast<std::size_t>(rows));
    w.jac[b].resize(static_cast<std::size_t>(rows * m));
  }
  int cur = 0;  // w.r[cur], w.jac[cur]: the current coefficients'; 1 - cur: the trial's
  auto r = [&](int b) { return Rows(w.r[b].data(), rows); };
  auto jac = [&](int b) { return JacRows(w.jac[b].data(), rows, m); };
  if (!Residual(ev, theta, w, w.r[0].data(), w.jac[0].data())) return kInf;
  double j = r(cur).squaredNorm();
  Eigen::MatrixXd a;  // J^T J
  Eigen::VectorXd g;  // J^T r
  auto normal_equations = [&]() {
    Eigen::MatrixXd low = Eigen::MatrixXd::Zero(m, m);  // lower half only: half the work
    low.selfadjointView<Eigen::Lower>().rankUpdate(jac(cur).transpose());
    a = low.selfadjointView<Eigen::Lower>();
    g.noalias() = jac(cur).transpose() * r(cur);
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
    const int trial = 1 - cur;
    if (Residual(ev, cand, w, w.r[trial].data(), w.jac[trial].data()) &&
        r(trial).squaredNorm() < j) {
      const double jn = r(trial).squaredNorm();
      const bool done = j - jn < kRelStop * j;
      theta = cand;
      cur = trial;
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
  if (jacobian != nullptr) *jacobian = jac(cur);
  if (residual != nullptr) *residual = r(cur);
  return j;
}

}  // namespace mrd::host::internal
