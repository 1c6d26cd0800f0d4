#pragma once
// `mrd-hil sweep SCENARIO --set KEY=FROM:TO:STEP [--set ...] [--out DIR]`: one lockstep run per
// grid point (progress on stderr), the table of scores on stdout, DIR/sweep.csv (atomic) and
// DIR/sweep.png (gnuplot: the score against the first swept key).

#include <atomic>
#include <string>
#include <vector>

#include "mrd/hil/run/run.hpp"

namespace mrd::hil {

// Exit status: 0 every point ran (whatever its pass/fail), 1 a run could not be made or a file
// not written, 2 bad input (a --set, the scenario, --firmware, --table), 128+N on signal N.
int SweepCommand(const std::string& scenario_path, const std::vector<std::string>& sets,
                 RunOptions options, const std::string& out_dir);

}  // namespace mrd::hil
