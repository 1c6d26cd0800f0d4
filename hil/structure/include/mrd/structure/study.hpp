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
  double peak_force_n = 0.0, rms_force_n = 0.0;        // damper force (the largest damper's)
  double mean_voltage = 0.0;                           // mean command (over the dampers) [V]
  // Per damper (dampers of them; 0 for the bare frame): its story, force and mean command.
  int dampers = 0;
  int story[ShearFrameParams::kMaxDampers] = {};
  double peak_force_each_n[ShearFrameParams::kMaxDampers] = {};
  double rms_force_each_n[ShearFrameParams::kMaxDampers] = {};
  double mean_voltage_each[ShearFrameParams::kMaxDampers] = {};
};

// Reads the damper stories of --dampers: a comma-separated list of distinct stories
// 1..kFloors in any order (e.g. "1" or "2,1"); sets frame->dampers and frame->story
// (ascending). false with *error = "--dampers: 'TEXT': reason" otherwise.
bool ParseDamperStories(const std::string& text, ShearFrameParams* frame, std::string* error);

// Runs one case on the frame's dampers (frame.dampers at frame.story; every one held at 0 V
// passive-off, at v_max passive-on); gains are used for kClippedOptimal only and must be of a
// design for as many dampers. Returns false with *error on bad options. progress: called per case
// with its name (may be null).
bool RunCase(Case which, const GroundRecord& record, const ShearFrameParams& frame,
             const SpencerParams& damper, const firmware::ClippedOptimalGains& gains,
             const StudyOptions& options, Response* out, std::string* error);

// Markdown table of the responses, one row per case; with several dampers, a per-damper table
// follows.
std::string ResponseTable(const std::vector<Response>& rows);

}  // namespace mrd::structure
