#pragma once
// The best passive baseline of a quarter car: the same car on the same road with the damper
// held at each constant voltage of a grid (E_min = 0 .. E_max, step [quarter_car]
// passive_step_v, default 0.05 V), in process and deterministic (the plant alone, no
// firmware). Per ride metric the best constant setting; the controlled run against it:
//
//   improvement [%] = 100 (best passive - controlled) / best passive   (> 0: controlled better)
//
// and comfort at equal road holding: the body-acceleration RMS improvement over the best
// passive setting whose tyre-load RMS is no worse (<=) than the controlled run's (none when
// every constant setting loads the tyre more than the controlled run).
// Body acceleration is also scored ISO 2631-1 Wk-weighted (iso2631_weighting.hpp): the filter
// runs from t = 0, the RMS over the samples after the settle time. Not real-time.

#include <cstddef>
#include <functional>
#include <vector>

#include "mrd/hil/plants/ride.hpp"

namespace mrd::hil {

struct Scenario;
struct RunResult;

// The scenario's plant (Spencer damper, car, road at 1 kHz).
QuarterCarPlant MakeQuarterCar(const Scenario& s);
// Progress callback: (point done, points); false stops the grid (e.g. on a signal).
using GridProgress = std::function<bool(std::size_t, std::size_t)>;
// The passive grid of a quarter-car scenario: 0 .. s.e_max in step_v. Empty on a bad step or
// when progress stopped it.
std::vector<RidePoint> RunPassiveGrid(const Scenario& s, double step_v,
                                      const GridProgress& progress = {});

// From a quarter-car run with its trace (RunResult::ride and trace): the grid at step_v, the
// controlled run's figures (its Wk RMS from the trace's body acceleration) and the PSDs.
// false when the run has no ride figures or trace, or step_v gives no grid.
bool ComputePassiveBaseline(const Scenario& s, const RunResult& r, double step_v,
                            PassiveBaseline* out, const GridProgress& progress = {});

}  // namespace mrd::hil
