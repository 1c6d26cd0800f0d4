// The one-step form of the selection's cross-validation (one_step_cv.hpp).
#include "sem/select/one_step_cv.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <limits>

namespace mrd::host::internal {
namespace {

// Per record: the terms' regressors over the scored rows (regressors from the measured output),
// row r of the matrix is record row first + r.
Eigen::MatrixXd Regressors(const Evaluator& e, const std::vector<SemTerm>& terms) {
  const Record& r = e.record();
  const auto rows = static_cast<Eigen::Index>(r.y.size() - r.first);
  Eigen::MatrixXd phi(rows, static_cast<Eigen::Index>(terms.size()));
  for (Eigen::Index i = 0; i < phi.cols(); ++i) {
    for (Eigen::Index k = 0; k < rows; ++k) {
      phi(k, i) =
          e.Term(terms[static_cast<std::size_t>(i)], r.y, r.first + static_cast<std::size_t>(k));
    }
  }
  return phi;
}

}  // namespace

Eigen::VectorXd SolveNormal(const Eigen::MatrixXd& g, const Eigen::VectorXd& b) {
  if (g.rows() == 0) return Eigen::VectorXd();
  Eigen::LLT<Eigen::MatrixXd> llt(g);
  return llt.info() == Eigen::Success
             ? Eigen::VectorXd(llt.solve(b))
             : Eigen::VectorXd(g.completeOrthogonalDecomposition().solve(b));
}

std::vector<Eigen::VectorXd> FitsWithoutEachFold(const std::vector<Eigen::MatrixXd>& g,
                                                 const std::vector<Eigen::VectorXd>& b) {
  const Eigen::Index m = g.empty() ? 0 : g.front().rows();
  Eigen::MatrixXd gt = Eigen::MatrixXd::Zero(m, m);
  Eigen::VectorXd bt = Eigen::VectorXd::Zero(m);
  for (std::size_t f = 0; f < g.size(); ++f) {
    gt += g[f];
    bt += b[f];
  }
  std::vector<Eigen::VectorXd> out(g.size());
  for (std::size_t f = 0; f < g.size(); ++f) {
    if (m > 0) out[f] = SolveNormal(gt - g[f], bt - b[f]);
  }
  return out;
}

std::vector<double> OneStepFoldCosts(const std::vector<Evaluator>& ev,
                                     const std::vector<SemTerm>& terms, int folds) {
  const auto m = static_cast<Eigen::Index>(terms.size());
  const auto nf = static_cast<std::size_t>(folds);
  std::vector<Eigen::MatrixXd> phi;
  std::vector<Eigen::MatrixXd> g(nf, Eigen::MatrixXd::Zero(m, m));
  std::vector<Eigen::VectorXd> b(nf, Eigen::VectorXd::Zero(m));
  for (const Evaluator& e : ev) {
    const Record& r = e.record();
    phi.push_back(Regressors(e, terms));
    for (int f = 0; f < folds; ++f) {
      const auto fi = static_cast<std::size_t>(f);
      const auto a = static_cast<Eigen::Index>(FoldBound(r, f, folds) - r.first);
      const auto len =
          static_cast<Eigen::Index>(FoldBound(r, f + 1, folds) - FoldBound(r, f, folds));
      const auto rows = phi.back().middleRows(a, len);
      const Eigen::Map<const Eigen::VectorXd> w(r.w.data() + r.first + a, len);
      const Eigen::Map<const Eigen::VectorXd> y(r.y.data() + r.first + a, len);
      g[fi].noalias() += rows.transpose() * w.asDiagonal() * rows;
      b[fi].noalias() += rows.transpose() * w.cwiseProduct(y);
    }
  }
  const std::vector<Eigen::VectorXd> fits = FitsWithoutEachFold(g, b);
  std::vector<double> out(nf, 0.0);
  for (int f = 0; f < folds; ++f) {
    const auto fi = static_cast<std::size_t>(f);
    const Eigen::VectorXd& theta = fits[fi];
    double cost = 0.0;
    for (std::size_t d = 0; d < ev.size(); ++d) {
      const Record& r = ev[d].record();
      const auto a = static_cast<Eigen::Index>(FoldBound(r, f, folds) - r.first);
      const auto len =
          static_cast<Eigen::Index>(FoldBound(r, f + 1, folds) - FoldBound(r, f, folds));
      const Eigen::Map<const Eigen::VectorXd> w(r.w.data() + r.first + a, len);
      const Eigen::Map<const Eigen::VectorXd> y(r.y.data() + r.first + a, len);
      const Eigen::VectorXd e =
          m > 0 ? Eigen::VectorXd(y - phi[d].middleRows(a, len) * theta) : Eigen::VectorXd(y);
      cost += w.dot(e.cwiseAbs2());
    }
    out[fi] = std::isfinite(cost) ? cost : std::numeric_limits<double>::infinity();
  }
  return out;
}

std::vector<double> OneStepResidual(const Evaluator& e, const std::vector<SemTerm>& terms) {
  const Record& r = e.record();
  const Eigen::MatrixXd phi = Regressors(e, terms);
  const auto rows = phi.rows();
  const Eigen::Map<const Eigen::VectorXd> w(r.w.data() + r.first, rows);
  const Eigen::Map<const Eigen::VectorXd> y(r.y.data() + r.first, rows);
  Eigen::VectorXd res = y;
  if (phi.cols() > 0) {
    res -= phi *
           SolveNormal(phi.transpose() * w.asDiagonal() * phi, phi.transpose() * w.cwiseProduct(y));
  }
  std::vector<double> out(static_cast<std::size_t>(rows));
  for (Eigen::Index k = 0; k < rows; ++k) {
    out[static_cast<std::size_t>(k)] = std::sqrt(w(k)) * res(k);
  }
  return out;
}

}  // namespace mrd::host::internal
