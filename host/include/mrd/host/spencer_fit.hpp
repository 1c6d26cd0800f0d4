#pragma once
// Fits the Spencer et al. 1997 phenomenological model (all 14 parameters, bounded) to measured
// damper data by nonlinear least squares (Ceres Solver, trust-region Levenberg-Marquardt,
// exact Jacobians of the simulator by forward sensitivities, host/src/spencer_sensitivity.hpp). The
// simulator is the harness's plant: SpencerDamper (common/sim/) stepped one sample at a time with
// RK4 sub-steps, the measured x and v interpolated as TracePlant does, the measured E of the
// interval's end held over it (as `mrd generate` and the harness's replay hold it; clamped to [0,
// e_max] as the firmware clamps it), started at rest at the first row with u = 0 V. Residual:
// simulated - measured force [N] at every sample.
//
// Multi-start: the presets paper and spencer1997 plus a deterministic scatter of starts
// (log-uniform around spencer1997, seed); each start is fitted on a search window (the first
// search_s seconds of each file), the starts in parallel threads; the best few are then
// polished on all rows, one after the other, each Jacobian's columns split over the threads. Units
// as spencer_damper.hpp (x cm, v cm/s, E V, f N).

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "mrd/sim/spencer_damper.hpp"

namespace mrd::host {

// One measured run at a uniform sampling interval dt [s].
struct FitRun {
  std::string name;  // for messages
  double dt = 1e-3;
  std::vector<double> x, v, E, f;
};

struct FitScore {
  double fit_percent = 0.0;  // 100 (1 - ||f - f^|| / ||f - mean f||); -inf when diverged
  double rmse_n = 0.0;       // [N]
  bool finite = true;        // false: the simulation diverged
};

struct SpencerFitOptions {
  int substeps = 20;       // RK4 steps per sample (the harness's [plant] substeps)
  double e_max = 2.25;     // [V] the measured E is clamped to [0, e_max]
  int scatter_starts = 6;  // starts besides the two presets
  std::uint64_t seed = 1;
  double search_s = 2.0;  // search window per file [s] (0: whole runs)
  int search_iterations = 12;
  int polish_starts = 1;  // best starts polished on all rows (one after the other)
  int polish_iterations = 30;
  int threads = 2;
  std::function<void(const std::string&)> progress;  // one line per event (may be empty)
};

struct SpencerFitStart {
  std::string label;          // "paper", "spencer1997", "scatter 3"
  double search_cost = 0.0;   // 0.5 sum r^2 on the search window after the search
  double polish_cost = -1.0;  // after the polish (-1: not polished)
  SpencerParams params;
};

struct SpencerFitResult {
  SpencerParams params;
  double cost = 0.0;  // 0.5 sum r^2 over all rows [N^2]
  std::vector<SpencerFitStart> starts;
};

// Lower and upper bounds of the fit (same order as params::SpencerFields).
void SpencerFitBounds(SpencerParams* lower, SpencerParams* upper);

// A fitted value within this share of its box's width from a bound counts as at the bound (the
// bounded solver ends on the bound itself; the boxes span decades, so the share is small).
inline constexpr double kAtBoundShare = 1e-6;

// Warnings about a fit ("warning: ..." lines, none when it looks sound): each parameter at a
// bound of SpencerFitBounds (the runs do not pin it), and x0 beyond the stroke the runs
// reached (k1 and x0 then trade off), each saying what to do.
std::vector<std::string> SpencerFitWarnings(const SpencerParams& fitted,
                                            const std::vector<FitRun>& runs);

// Simulated force at every row of run (the harness's replay of it, open loop). false when the
// simulation turned non-finite (f_hat then holds what was computed).
bool SimulateRunForce(const SpencerParams& p, const FitRun& run, int substeps, double e_max,
                      std::vector<double>* f_hat);
FitScore ScoreRun(const SpencerParams& p, const FitRun& run, int substeps, double e_max);

// Throws std::invalid_argument on empty runs or bad options.
SpencerFitResult FitSpencer(const std::vector<FitRun>& runs, const SpencerFitOptions& o);

}  // namespace mrd::host
