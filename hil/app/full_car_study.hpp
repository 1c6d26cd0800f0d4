#pragma once
// `mrd-hil study` on a full-car scenario ([plant] model = "full-car", docs/study.md): per motion
// ratio x road class x speed the passive grids (all four dampers at one constant voltage, 0 ..
// E_max in the passive step; and front / rear apart, a grid in the scenario's pair_step_v) and
// each law of full_car_law.hpp (per-corner firmware laws, modal skyhook), on the same two-track
// road (the scenario's seed and coherence). Per run: comfort (body acceleration RMS at the
// centre of gravity, plain and ISO 2631-1 Wk weighted), pitch and roll rate RMS, tyre-load RMS
// per wheel (full_car_ride.hpp). Each law against the best passive setting of both grids whose
// worst wheel's tyre-load RMS is no worse than the law's:
//   improvement [%] = 100 (best passive Wk - law Wk) / best passive Wk
// Writes DIR/study.txt, study.csv, study.json (atomic) and plots (gnuplot). Deterministic.

#include "mrd/hil/scenario/scenario.hpp"
#include "study_command.hpp"

namespace mrd::hil {

// base: the scenario as loaded (full_car). Exit status as StudyCommand's.
int FullCarStudyCommand(const StudyOptions& options, const Scenario& base);

}  // namespace mrd::hil
