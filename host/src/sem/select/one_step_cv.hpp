#pragma once
// The one-step (prediction-error) form of the selection's cross-validation, and the fold helpers
// it shares with the free-run form (selection.cpp). The one-step form is used when the noise is
// taken to be in the equation (spec selection_noise).
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "mrd/host/sem.hpp"
#include "sem/estimate/evaluator.hpp"

namespace mrd::host::internal {

// Fold boundaries of a record's scored rows: part f of `folds` is
// [FoldBound(f), FoldBound(f + 1)), contiguous in time.
inline std::size_t FoldBound(const Record& r, int f, int folds) {
  const std::size_t n = r.y.size() - r.first;
  return r.first + n * static_cast<std::size_t>(f) / static_cast<std::size_t>(folds);
}

// Solves the normal equations g theta = b (Cholesky); the minimum-norm solution when g is not
// positive definite. Empty g: an empty theta.
Eigen::VectorXd SolveNormal(const Eigen::MatrixXd& g, const Eigen::VectorXd& b);

// Per fold f, the fit on every other fold: from the per-fold normal equations (Gram matrices g,
// right-hand sides b) their totals over all folds less fold f's own, solved (SolveNormal).
// No terms (0 x 0 matrices): empty solutions.
std::vector<Eigen::VectorXd> FitsWithoutEachFold(const std::vector<Eigen::MatrixXd>& g,
                                                 const std::vector<Eigen::VectorXd>& b);

// Per fold f: the weighted least squares on every other fold of every record, and the weighted
// one-step squared error sum_k w_k (y_k - phi_k theta)^2 over fold f (regressors from the
// measured output), summed over records; +inf for a fold whose sum is not finite. With noise in
// the equation this is the likelihood, which the free-run error is not.
std::vector<double> OneStepFoldCosts(const std::vector<Evaluator>& ev,
                                     const std::vector<SemTerm>& terms, int folds);

// Weighted one-step residual sqrt(w_k) (y_k - phi_k theta) of one record over its scored rows,
// theta the weighted least squares on that record.
std::vector<double> OneStepResidual(const Evaluator& e, const std::vector<SemTerm>& terms);

}  // namespace mrd::host::internal
