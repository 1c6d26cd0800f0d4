#pragma once
// `mrd-hil study`: the comfort / road-holding study of a quarter-car scenario (docs/study.md);
// a full-car scenario runs full_car_study.hpp's.
// For each motion ratio x road class x speed it runs the best-passive grid (every constant voltage)
// and each firmware law in process (firmware_law.hpp) on the same road (the scenario's seed), and
// tabulates per case the best passive comfort and each law's body-acceleration RMS improvement
// over the best passive setting whose tyre-load RMS is no worse than the law's. Writes
// DIR/study.txt, study.csv, study.json (atomic) and plots (gnuplot). Deterministic.

#include <string>
#include <vector>

namespace mrd::hil {

struct StudyOptions {
  std::string scenario;
  std::string classes = "B,C,D";                // ISO 8608 classes, comma-separated
  std::string speeds = "10,20,30";              // [m/s], comma-separated
  std::string motion_ratios;                    // damper / wheel travel, comma-separated; "":
                                                // the scenario's
  std::string laws = "skyhook,skyhook-on-off";  // NAME[:KEY=VALUE...], comma-separated
  bool laws_given = false;       // --laws given (a full car has its own default list)
  double duration_s = -1.0;      // < 0: the scenario's
  double passive_step_v = -1.0;  // < 0: the scenario's
  std::string out_dir;           // "": study-NAME
  bool json = false;             // print the JSON instead of the table
};

// Exit status: 0 done, 1 a file could not be written, 2 bad input (names the flag).
int StudyCommand(const StudyOptions& options);

}  // namespace mrd::hil
