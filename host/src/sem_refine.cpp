// Output-error refinement of a structure's coefficients (sem_internal.hpp): Levenberg-Marquardt
// on the free-run cost J, started from the one-step least squares. Least squares on the one-step
// regression is biased when the noise enters the output (the measured output in the regressors
// is noisy); minimising J itself removes that bias, so a spurious term no longer lowers J by
// compensating it.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>
#include <limits>

#include <Eigen/Dense>

#include "sem_evaluator.hpp"
#include "sem_internal.hpp"

namespace mrd::host::internal {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxSteps = 30;           // LM steps (accepted or not)
constexpr double kRelStop = 1e-6;       // stop when an accepted step lowers J by less
constexpr double kDiffStep = 1e-6;      // forward-difference step, relative (abs floor 1e-8)

// Weighted free-run residual sqrt(w_k) (y_k - ysim_k) over every scored row of every record;
// false when a run diverges.
bool Residual(const std::vector<Evaluator>& ev, const std::vector<Evaluator::Prepared>& prepared,
              const Eigen::VectorXd& theta, Eigen::VectorXd* r) {
  std::vector<double> all, e, ys;
  for (std::size_t i = 0; i < ev.size(); ++i) {
    const Record& rec = ev[i].record();
    e.clear();
    if (!std::isfinite(ev[i].FreeRun(prepared[i], theta, rec.first, rec.y.size(), ys, &e))) {
      return false;
    }
    for (std::size_t k = 0; k < e.size(); ++k) {
      all.push_back(std::sqrt(rec.w[rec.first + k]) * e[k]);
    }
  }
  *r = Eigen::Map<Eigen::VectorXd>(all.data(), static_cast<Eigen::Index>(all.size()));
  return true;
}

}  // namespace

double RefineFreeRun(const std::vector<Evaluator>& ev, const std::vector<SemTerm>& terms,
                     std::vector<double>* coefficients, int threads,
                     Eigen::MatrixXd* jacobian, Eigen::VectorXd* residual) {
  const auto m = static_cast<Eigen::Index>(terms.size());
  Eigen::VectorXd theta(m);
  for (Eigen::Index i = 0; i < m; ++i) theta(i) = (*coefficients)[static_cast<std::size_t>(i)];
  std::vector<Evaluator::Prepared> prepared;
  for (const Evaluator& e : ev) prepared.push_back(e.Prepare(terms));
  Eigen::VectorXd r;
  if (!Residual(ev, prepared, theta, &r)) return kInf;
  double j = r.squaredNorm();
  if (residual != nullptr) *residual = r;
  if (jacobian != nullptr) jacobian->resize(r.size(), m);
  if (m == 0) return j;
  double lambda = -1.0;
  Eigen::MatrixXd jac(r.size(), m);
  Eigen::VectorXd rt;
  bool fresh = false;  // jac belongs to theta
  auto differentiate = [&]() {  // d residual / d theta, forward (else backward) differences
    std::atomic<bool> ok{true};
    auto column = [&](Eigen::Index c) {
      Eigen::VectorXd tp = theta, rc;
      const double h = kDiffStep * std::max(std::fabs(theta(c)), 1e-2);
      tp(c) += h;
      if (Residual(ev, prepared, tp, &rc)) {
        jac.col(c) = (rc - r) / h;
        return;
      }
      tp(c) = theta(c) - h;
      if (Residual(ev, prepared, tp, &rc)) {
        jac.col(c) = (r - rc) / h;
      } else {
        ok = false;  // on the edge of divergence
      }
    };
    const int w = std::max(1, std::min<int>(threads, static_cast<int>(m)));
    std::vector<std::thread> pool;
    for (int t = 0; t < w; ++t) {
      pool.emplace_back([&, t] {
        for (Eigen::Index c = t; c < m; c += w) column(c);
      });
    }
    for (auto& t : pool) t.join();
    fresh = ok;
    return ok.load();
  };
  for (int step = 0; step < kMaxSteps; ++step) {
    if (!fresh && !differentiate()) break;
    const Eigen::MatrixXd a = jac.transpose() * jac;
    const Eigen::VectorXd g = jac.transpose() * r;
    if (lambda < 0.0) lambda = 1e-3 * a.diagonal().maxCoeff();
    Eigen::MatrixXd damped = a;
    damped.diagonal() += lambda * a.diagonal().cwiseMax(1e-12 * a.diagonal().maxCoeff());
    const Eigen::VectorXd delta = damped.ldlt().solve(-g);
    if (!delta.allFinite()) break;
    const Eigen::VectorXd cand = theta + delta;
    if (Residual(ev, prepared, cand, &rt) && rt.squaredNorm() < j) {
      const double jn = rt.squaredNorm();
      const bool done = j - jn < kRelStop * j;
      theta = cand;
      r = rt;
      j = jn;
      lambda *= 0.2;
      fresh = false;
      if (done) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e12 * a.diagonal().maxCoeff()) break;
    }
  }
  for (Eigen::Index i = 0; i < m; ++i) (*coefficients)[static_cast<std::size_t>(i)] = theta(i);
  if (jacobian != nullptr) {
    if (!fresh && !differentiate()) jac.setZero();
    *jacobian = jac;
  }
  if (residual != nullptr) *residual = r;
  return j;
}

}  // namespace mrd::host::internal
