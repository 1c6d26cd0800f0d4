#pragma once
// Replay of a measured run ([excitation] kind = "replay", file = "RUN.csv" with columns x, v,
// E, f as `mrd import` / `mrd generate` write them, one row per 1 ms period): the plant is
// driven with the measured motion (x, v). The demand the firmware reads is
//   law "force":     the measured force f [N] (demand_column, default "f");
//   law "open-loop": the measured command E in mV (E * 1000; the firmware's open-loop law
//                    passes E / 1000 through, clamped to [E_min, E_max]); the sample of row
//                    k carries E of row k + 1, so step k (row k -> k + 1) is driven with
//                    E(k + 1) as `mrd generate` and `mrd fit-spencer` hold it.
// The run's summary then scores (run_scores.cpp) the plant's force against the measured f (fit %,
// RMSE): a check of the plant itself, before any closed loop. Start-up parsing only.

#include <cstdint>
#include <string>
#include <vector>

#include "mrd/hil/plants/plant.hpp"

namespace mrd::hil {

// The measured force per row [N] (row k is plant time k ms).
struct ReplayRun {
  std::vector<double> f;
};

// false: *error = "FILE:LINE: reason" (missing columns name the missing ones).
bool LoadReplay(const std::string& path, bool open_loop, const std::string& demand_column,
                Trace* trace, ReplayRun* run, std::string* error);

struct ReplayScores {
  std::uint64_t samples = 0;
  double fit_percent = 0.0;  // 100 (1 - ||f - f_plant|| / ||f - mean f||)
  double rmse_n = 0.0;       // [N]
};

}  // namespace mrd::hil
