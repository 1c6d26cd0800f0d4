#pragma once
// Between the scenario loop (run.cpp) and its scoring (run_scores.cpp).

#include "mrd/hil/run.hpp"

namespace mrd::hil {

// Tracking scores and per-fault figures from r->trace.
void ScoreRun(const Scenario& s, RunResult* r);
// r->pass and r->failures from the scenario's criteria.
void EvaluatePass(const Scenario& s, RunResult* r);

}  // namespace mrd::hil
