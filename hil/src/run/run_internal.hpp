#pragma once
// Between the scenario loops (run.cpp, the four-corner run) and their shared parts (scoring in
// run_scores.cpp, helpers in run_support.cpp).

#include <vector>

#include "mrd/hil/run/run.hpp"

namespace mrd::hil {

// The port's sensor fault for a scheduled fault of the scenario (kNone: not a sensor fault).
SensorFault SensorFaultOf(FaultKind k);

// Tracking scores and per-fault figures from r->trace.
void ScoreRun(const Scenario& s, RunResult* r);
// r->pass and r->failures from the scenario's criteria.
void EvaluatePass(const Scenario& s, RunResult* r);
// A replay's plant force against the measured f (plants/replay.hpp): step k's record (the
// sample after step k) against measured row k + 1; rows past the file's end are not scored.
ReplayScores ScoreReplay(const std::vector<StepRecord>& trace, const ReplayRun& run);

}  // namespace mrd::hil
