#pragma once
// Between the scenario loop (run.cpp) and its scoring (run_scores.cpp).

#include <vector>

#include "mrd/hil/run/run.hpp"

namespace mrd::hil {

// Tracking scores and per-fault figures from r->trace.
void ScoreRun(const Scenario& s, RunResult* r);
// r->pass and r->failures from the scenario's criteria.
void EvaluatePass(const Scenario& s, RunResult* r);
// A replay's plant force against the measured f (plants/replay.hpp): step k's record (the
// sample after step k) against measured row k + 1; rows past the file's end are not scored.
ReplayScores ScoreReplay(const std::vector<StepRecord>& trace, const ReplayRun& run);

}  // namespace mrd::hil
