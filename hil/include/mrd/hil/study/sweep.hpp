#pragma once
// `mrd-hil sweep`: a grid of scenario overrides (--set KEY=FROM:TO:STEP, cartesian product;
// a plain KEY=VALUE fixes a key) and the scores each point's run gives.

#include <cstddef>
#include <string>
#include <vector>

#include "mrd/hil/run/run.hpp"
#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil {

constexpr std::size_t kMaxSweepPoints = 1000;  // runs in one sweep

struct SweepAxis {
  std::string key;                  // dotted scenario key
  std::vector<std::string> values;  // TOML numbers, FROM, FROM+STEP, ... up to TO
};

struct SweepGrid {
  std::vector<std::string> fixed;  // plain KEY=VALUE sets, applied to every point
  std::vector<SweepAxis> axes;     // in --set order; the first varies fastest
  // The points (each the KEY=VALUE sets of the swept keys, in axis order).
  std::vector<std::vector<std::string>> Points() const;
};

// Splits the --set list. A VALUE with ':' (not a quoted string) is a range FROM:TO:STEP of
// finite numbers: STEP != 0 and of the sign of TO - FROM (FROM == TO: one point); the values
// are FROM + i*STEP (12 significant digits) up to TO (inclusive, within 1e-9 of a step).
// Refused ("--set 'SPEC': reason"): no '=', a range that is not three numbers, STEP 0 or of
// the wrong sign, a key swept twice, no swept key at all, more than kMaxSweepPoints points.
bool ParseSweepGrid(const std::vector<std::string>& sets, SweepGrid* grid, std::string* error);

// The scores of one run, as the run's summary gives them (NaN where the scenario has none).
struct SweepScores {
  bool pass = false;
  std::uint64_t invariant_violations = 0;
  double error_all = 0.0, error_reachable = 0.0;  // force tracking
  double reachable_share = 0.0;                   // of the controlled steps
  bool ride = false;                              // quarter car: the figures below
  double body_accel_rms = 0.0, travel_rms_cm = 0.0, tyre_load_rms_n = 0.0;
  double body_accel_off = 0.0, body_accel_on = 0.0;  // passive twins [m/s^2]
  std::string table, plant;  // what the point ran on (TableLabel, PlantLabel): set by the caller
};
SweepScores ScoresOf(const RunResult& r);

// The CSV (header: the swept keys, then the score columns, then table and plant; one row per
// point).
std::string SweepCsv(const SweepGrid& grid, const std::vector<SweepScores>& rows);
// The table printed on stdout (aligned columns; best point marked).
std::string SweepTable(const SweepGrid& grid, const std::vector<SweepScores>& rows);
// The index of the best point: the lowest body acceleration RMS (quarter car) or reachable
// tracking error, passing points first; rows.size() when empty.
std::size_t BestPoint(const std::vector<SweepScores>& rows);

}  // namespace mrd::hil
