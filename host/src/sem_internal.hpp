#pragma once
// Shared by the SEM engine (sem.cpp) and its model selection (sem_selection.cpp); not public.

#include <span>
#include <vector>

#include "mrd/host/sem.hpp"

namespace mrd::host::internal {

// One elementary regressor over a whole record of raw values: T(raw / scale). Low-pass
// filters start from r(-1) = 0 at the record's first sample, as ModelRunner after Reset.
std::vector<double> TransformSignal(const ElementaryRegressor& reg, const std::vector<double>& raw,
                                    double scale);

// Picks res->selected among res->iterations and states the rule in res->selection_rule:
// the validation rule when validation J is present, else spec.selection (docs in sem.hpp).
void SelectModel(const SemSpec& spec, std::span<const DataSet> identification, int threads,
                 SemResult* res);

}  // namespace mrd::host::internal
