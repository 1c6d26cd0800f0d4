#pragma once
// The structure study: the shear frame (shear_frame.hpp) under a ground-acceleration record,
// run in one process against the firmware's clipped-optimal law (clipped_optimal.hpp) and the
// passive cases, deterministic (no clock, no threads). Host only.

#include <string>
#include <vector>

#include "mrd/common/ground_record.hpp"
#include "mrd/sim/shear_frame.hpp"
#include "mrd/structure/design.hpp"

namespace mrd::structure {

enum class Case { kUncontrolled, kPassiveOff, kPassiveOn, kClippedOptimal };
const char* CaseName(Case c);

struct StudyOptions {
  double time_scale = 5.0;  // the record is played this many times faster (scaled model)
  double amplitude = 1.0;   // factor on the record's acceleration
  double g = 9.81;          // [m/s^2]
  int substeps = 20;        // RK4 steps of the plant per control period
  double tail_s = 1.0;      // free vibration after the record [s]
  DesignOptions design;     // period, LQG weights, v_max (the passive-on voltage too)
};

struct Response {
  Case which = Case::kUncontrolled;
  double peak_x_cm[3] = {}, rms_x_cm[3] = {};          // floor displacement rel. ground
  double peak_d_cm[3] = {}, rms_d_cm[3] = {};          // inter-story drift
  double peak_xa_cm_s2[3] = {}, rms_xa_cm_s2[3] = {};  // absolute acceleration
  double peak_force_n = 0.0, rms_force_n = 0.0;        // damper force
  double mean_voltage = 0.0;                           // mean command [V]
};

// Runs one case; gains are used for kClippedOptimal only. Returns false with *error on bad
// options. progress: called per case with its name (may be null).
bool RunCase(Case which, const GroundRecord& record, const ShearFrameParams& frame,
             const SpencerParams& damper, const firmware::ClippedOptimalGains& gains,
             const StudyOptions& options, Response* out, std::string* error);

// Markdown table of the responses, one row per case.
std::string ResponseTable(const std::vector<Response>& rows);

}  // namespace mrd::structure
