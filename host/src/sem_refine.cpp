// Output-error refinement of a structure's coefficients (sem_internal.hpp): Levenberg-Marquardt
// on the free-run cost J, started from the one-step least squares. Least squares on the one-step
// regression is biased when the noise enters the output (the measured output in the regressors
// is noisy); minimising J itself removes that bias, so a spurious term no longer lowers J by
// compensating it.
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "sem_evaluator.hpp"
#include "sem_internal.hpp"

namespace mrd::host::internal {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxSteps = 30;      // LM steps (accepted or not)
constexpr double kRelStop = 1e-6;  // stop when an accepted step lowers J by less

// Weighted free-run residual r_k = sqrt(w_k) (y_k - ysim_k) over every scored row of every
// record, and its Jacobian d r / d theta = -sqrt(w_k) d ysim_k / d theta from the sensitivity
// recursion (exact, one pass for all columns); false when a run diverges.
bool Residual(const std::vector<Evaluator>& ev, const std::vector<Evaluator::Prepared>& prepared,
              const Eigen::VectorXd& theta, Eigen::VectorXd* r, Eigen::MatrixXd* jac) {
  const auto m = static_cast<std::size_t>(theta.size());
  Eigen::Index rows = 0;
  for (const Evaluator& e : ev) {
    rows += static_cast<Eigen::Index>(e.record().y.size() - e.record().first);
  }
  r->resize(rows);
  jac->resize(rows, theta.size());
  std::vector<double> e, ys, sens;
  Eigen::Index row = 0;
  for (std::size_t i = 0; i < ev.size(); ++i) {
    const Record& rec = ev[i].record();
    e.clear();
    const double cost = ev[i].FreeRun(prepared[i], theta, rec.first, rec.y.size(), ys, &e, &sens);
    if (!std::isfinite(cost)) {
      return false;
    }
    for (std::size_t k = 0; k < e.size(); ++k, ++row) {
      const double sw = std::sqrt(rec.w[rec.first + k]);
      (*r)(row) = sw * e[k];
      for (std::size_t j = 0; j < m; ++j) {
        (*jac)(row, static_cast<Eigen::Index>(j)) = -sw * sens[k * m + j];
      }
    }
  }
  return true;
}

}  // namespace

double RefineFreeRun(const std::vector<Evaluator>& ev, const std::vector<SemTerm>& terms,
                     std::vector<double>* coefficients, Eigen::MatrixXd* jacobian,
                     Eigen::VectorXd* residual) {
  const auto m = static_cast<Eigen::Index>(terms.size());
  Eigen::VectorXd theta(m);
  for (Eigen::Index i = 0; i < m; ++i) theta(i) = (*coefficients)[static_cast<std::size_t>(i)];
  std::vector<Evaluator::Prepared> prepared;
  for (const Evaluator& e : ev) prepared.push_back(e.Prepare(terms));
  Eigen::VectorXd r, rt;
  Eigen::MatrixXd jac, jt;
  if (!Residual(ev, prepared, theta, &r, &jac)) return kInf;
  double j = r.squaredNorm();
  double lambda = -1.0;
  for (int step = 0; step < kMaxSteps && m > 0; ++step) {
    const Eigen::MatrixXd a = jac.transpose() * jac;
    const Eigen::VectorXd g = jac.transpose() * r;
    if (lambda < 0.0) lambda = 1e-3 * a.diagonal().maxCoeff();
    Eigen::MatrixXd damped = a;
    damped.diagonal() += lambda * a.diagonal().cwiseMax(1e-12 * a.diagonal().maxCoeff());
    const Eigen::VectorXd delta = damped.ldlt().solve(-g);
    if (!delta.allFinite()) break;
    const Eigen::VectorXd cand = theta + delta;
    if (Residual(ev, prepared, cand, &rt, &jt) && rt.squaredNorm() < j) {
      const double jn = rt.squaredNorm();
      const bool done = j - jn < kRelStop * j;
      theta = cand;
      r.swap(rt);
      jac.swap(jt);
      j = jn;
      lambda *= 0.2;
      if (done) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e12 * a.diagonal().maxCoeff()) break;
    }
  }
  for (Eigen::Index i = 0; i < m; ++i) (*coefficients)[static_cast<std::size_t>(i)] = theta(i);
  if (jacobian != nullptr) *jacobian = jac;
  if (residual != nullptr) *residual = r;
  return j;
}

}  // namespace mrd::host::internal
