#pragma once
// Shared by the SEM engine (sem/identify.cpp, sem/engine/, sem/search/) and its model
// selection (sem/select/selection.cpp); not public.

#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "mrd/host/sem.hpp"

namespace mrd::host::internal {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

class Evaluator;         // host/src/sem/estimate/evaluator.hpp
struct RefineWorkspace;  // ditto

// Jacobian of the weighted free-run residual, one row per scored row (row-major: the free
// run's sensitivities are produced row by row).
using Jacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Output-error refinement: Levenberg-Marquardt on the free-run J of `terms` over the records,
// from *coefficients (normalised units, replaced by the refined ones). Returns the refined J
// (never above the start's; +inf when the start diverges). Analytic Jacobian (the free run's
// sensitivity recursion): about two free runs' work per step.
// jacobian / residual (optional): d residual / d coefficient and the weighted residual
// sqrt(w) (y - ysim) at the refined coefficients, rows = scored rows of every record in order.
// ws (optional): buffers kept across calls (one call at a time), so repeated refinements
// allocate and touch no fresh memory; without it the calling thread's own; the result does not
// depend on it.
double RefineFreeRun(const std::vector<Evaluator>& ev, const std::vector<SemTerm>& terms,
                     std::vector<double>* coefficients, Jacobian* jacobian = nullptr,
                     Eigen::VectorXd* residual = nullptr, RefineWorkspace* ws = nullptr);

// Every signal of the spec is a column of every data set (InputError with the spec's line of
// the signal) and every set is longer than the largest delay + 1 (InputError).
void CheckData(const SemSpec& spec, std::span<const DataSet> data);

// One elementary regressor over a whole record of raw values: T(raw / scale). Low-pass
// filters start from r(-1) = 0 at the record's first sample, as ModelRunner after Reset.
std::vector<double> TransformSignal(const ElementaryRegressor& reg, const std::vector<double>& raw,
                                    double scale);

// The score a cross-validated selection ranked the iterations by, for structures off the
// search path: the same folds, prefilter, N and C (SelectByCrossValidation in sem.hpp).
struct SelectionCriterion {
  // Per-fold costs of terms from the start *coefficients (least squares; replaced by the
  // refined ones when spec.refine), their J in *j.
  std::function<std::vector<double>(const std::vector<SemTerm>& terms,
                                    std::vector<double>* coefficients, double* j)>
      fold_costs;
  double samples = 0.0;     // N
  double candidates = 0.0;  // C
  // CrossValidationScore (sem.hpp) of a structure of m terms with these per-fold costs.
  double Score(const std::vector<double>& costs, std::size_t m) const;
  explicit operator bool() const { return static_cast<bool>(fold_costs); }
};

// Picks res->selected among res->iterations and states the rule in res->selection_rule:
// the validation rule when validation J is present, else spec.selection (docs in sem.hpp).
// criterion (optional): set to the cross-validated score when that rule picked, else empty.
void SelectModel(const SemSpec& spec, std::span<const DataSet> identification, int threads,
                 SemResult* res, SelectionCriterion* criterion = nullptr);

}  // namespace mrd::host::internal
