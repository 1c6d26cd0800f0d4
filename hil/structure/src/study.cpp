#include "mrd/structure/study.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "mrd/firmware/clipped_optimal.hpp"
#include "mrd/hil/plants/structure_scores.hpp"

namespace mrd::structure {

const char* CaseName(Case c) {
  switch (c) {
    case Case::kUncontrolled:
      return "uncontrolled";
    case Case::kPassiveOff:
      return "passive-off";
    case Case::kPassiveOn:
      return "passive-on";
    case Case::kClippedOptimal:
      return "clipped-optimal";
  }
  return "unknown";
}

bool ParseDamperStories(const std::string& text, ShearFrameParams* frame, std::string* error) {
  constexpr int kFloors = ShearFrameParams::kFloors;
  const auto refuse = [&](const std::string& why) {
    *error = "--dampers: '" + text + "': " + why + " (stories 1 to " + std::to_string(kFloors) +
             ", comma-separated, e.g. 1,2)";
    return false;
  };
  bool used[kFloors + 1] = {};
  std::size_t pos = 0;
  while (true) {
    const std::size_t comma = text.find(',', pos);
    const std::string item = text.substr(pos, comma == std::string::npos ? comma : comma - pos);
    if (item.size() != 1 || item[0] < '1' || item[0] > '0' + kFloors) {
      return refuse(item.empty() ? "an empty story" : "'" + item + "' is not a story");
    }
    const int story = item[0] - '0';
    if (used[story]) return refuse("story " + item + " twice");
    used[story] = true;
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  frame->dampers = 0;
  for (int story = 1; story <= kFloors; ++story) {
    if (used[story]) frame->story[frame->dampers++] = story;
  }
  return true;
}

bool RunCase(Case which, const GroundRecord& record, const ShearFrameParams& frame_params,
             const SpencerParams& damper, const firmware::ClippedOptimalGains& gains,
             const StudyOptions& o, Response* out, std::string* error) {
  if (!(o.time_scale > 0.0) || !std::isfinite(o.amplitude) || !(o.design.period_s > 0.0) ||
      o.substeps < 1 || !(o.tail_s >= 0.0) || record.ag_g.size() < 2) {
    *error = "study: time_scale, period must be > 0, substeps >= 1, tail >= 0";
    return false;
  }
  ShearFrameParams fp = frame_params;
  fp.with_damper = which != Case::kUncontrolled;
  const char* reason = nullptr;
  if (!fp.IsValid(&reason)) {
    *error = std::string("study: invalid frame parameter ") + reason;
    return false;
  }
  const double T = o.design.period_s;
  const double dt_rec = record.dt_s / o.time_scale;  // scaled record spacing [s]
  const double record_s = dt_rec * static_cast<double>(record.ag_g.size() - 1);
  const auto ag_at = [&](double t) {  // [m/s^2], linear, 0 after the record
    if (t >= record_s) return 0.0;
    const double pos = t / dt_rec;
    const auto i = static_cast<std::size_t>(pos);
    const double w = pos - static_cast<double>(i);
    return o.amplitude * o.g * (record.ag_g[i] * (1.0 - w) + record.ag_g[i + 1] * w);
  };
  const long steps = std::lround((record_s + o.tail_s) / T);

  double e_const = 0.0;
  if (which == Case::kPassiveOn) e_const = o.design.v_max;
  ShearFrame frame(fp, damper, o.substeps);
  frame.Reset(e_const, ag_at(0.0));
  firmware::ClippedOptimal law;
  law.Configure(gains);
  const int nd = fp.with_damper ? fp.dampers : 0;
  if (which == Case::kClippedOptimal && law.dampers() != nd) {
    *error = "study: the gains are for " + std::to_string(law.dampers()) +
             " damper(s), the frame has " + std::to_string(nd);
    return false;
  }

  Response r;
  r.which = which;
  hil::StructureMetrics metrics;  // the harness's accumulation (structure_scores.hpp)
  double sum_e = 0.0;
  constexpr int kD = ShearFrameParams::kMaxDampers;
  double peak_f[kD] = {}, sum_f2[kD] = {}, sum_ej[kD] = {};
  ShearFrameSample s = frame.sample();
  for (long k = 0; k < steps; ++k) {
    double E[kD] = {e_const, e_const, e_const};
    if (which == Case::kClippedOptimal) {
      firmware::Real accel[3], force[kD] = {}, volts[kD] = {};
      for (int i = 0; i < 3; ++i) accel[i] = static_cast<firmware::Real>(s.xa[i]);
      for (int j = 0; j < nd; ++j) force[j] = static_cast<firmware::Real>(s.forces[j]);
      law.Update(accel, force, volts);
      for (int j = 0; j < nd; ++j) E[j] = static_cast<double>(volts[j]);
    }
    sum_e += E[0];
    const double t0 = static_cast<double>(k) * T;
    s = frame.Step(T, ag_at(t0), ag_at(t0 + T), E);
    metrics.Add(s);
    for (int j = 0; j < nd; ++j) {
      peak_f[j] = std::fmax(peak_f[j], std::fabs(s.forces[j]));
      sum_f2[j] += s.forces[j] * s.forces[j];
      sum_ej[j] += E[j];
    }
    if (!std::isfinite(s.x[2]) || !std::isfinite(s.force)) {
      *error = std::string("study: ") + CaseName(which) + " diverged at t = " + std::to_string(t0) +
               " s";
      return false;
    }
  }
  const double n = static_cast<double>(steps);
  const hil::StructureFigures f = metrics.Figures();
  for (int i = 0; i < 3; ++i) {
    r.peak_x_cm[i] = f.peak_x_cm[i];
    r.peak_d_cm[i] = f.peak_d_cm[i];
    r.peak_xa_cm_s2[i] = f.peak_xa_cm_s2[i];
    r.rms_x_cm[i] = f.rms_x_cm[i];
    r.rms_d_cm[i] = f.rms_d_cm[i];
    r.rms_xa_cm_s2[i] = f.rms_xa_cm_s2[i];
  }
  r.peak_force_n = f.peak_force_n;
  r.rms_force_n = f.rms_force_n;
  r.mean_voltage = sum_e / n;
  r.dampers = nd;
  for (int j = 0; j < nd; ++j) {
    r.story[j] = fp.story[j];
    r.peak_force_each_n[j] = peak_f[j];
    r.rms_force_each_n[j] = std::sqrt(sum_f2[j] / n);
    r.mean_voltage_each[j] = sum_ej[j] / n;
  }
  if (nd > 1) {  // the table's mean E: over every damper
    double sum = 0.0;
    for (int j = 0; j < nd; ++j) sum += r.mean_voltage_each[j];
    r.mean_voltage = sum / nd;
  }
  for (int j = 1; j < nd; ++j) {  // the table's f: the largest damper's
    r.peak_force_n = std::fmax(r.peak_force_n, peak_f[j]);
    r.rms_force_n = std::fmax(r.rms_force_n, r.rms_force_each_n[j]);
  }
  *out = r;
  return true;
}

std::string ResponseTable(const std::vector<Response>& rows) {
  std::ostringstream out;
  char buf[512];
  out << "Peak responses (x, d [cm]; xa [cm/s^2]; f [N]):\n\n"
         "| case | x1 | x2 | x3 | d1 | d2 | d3 | xa1 | xa2 | xa3 | f |\n"
         "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Response& r : rows) {
    std::snprintf(buf, sizeof buf,
                  "| %s | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.0f | %.0f | %.0f | %.0f |\n",
                  CaseName(r.which), r.peak_x_cm[0], r.peak_x_cm[1], r.peak_x_cm[2], r.peak_d_cm[0],
                  r.peak_d_cm[1], r.peak_d_cm[2], r.peak_xa_cm_s2[0], r.peak_xa_cm_s2[1],
                  r.peak_xa_cm_s2[2], r.peak_force_n);
    out << buf;
  }
  out << "\nRMS responses (same units; mean command E [V]):\n\n"
         "| case | x1 | x2 | x3 | d1 | d2 | d3 | xa1 | xa2 | xa3 | f | mean E |\n"
         "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Response& r : rows) {
    std::snprintf(
        buf, sizeof buf,
        "| %s | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.0f | %.0f | %.0f | %.0f | %.2f |\n",
        CaseName(r.which), r.rms_x_cm[0], r.rms_x_cm[1], r.rms_x_cm[2], r.rms_d_cm[0],
        r.rms_d_cm[1], r.rms_d_cm[2], r.rms_xa_cm_s2[0], r.rms_xa_cm_s2[1], r.rms_xa_cm_s2[2],
        r.rms_force_n, r.mean_voltage);
    out << buf;
  }
  bool several = false;
  for (const Response& r : rows) several = several || r.dampers > 1;
  if (!several) return out.str();
  out << "\nPer damper (f: peak / RMS force [N], mean command E [V]; the tables' f is the "
         "largest):\n\n| case | damper (story) | peak f | RMS f | mean E "
         "|\n|---|---|---|---|---|\n";
  for (const Response& r : rows) {
    for (int j = 0; j < r.dampers; ++j) {
      std::snprintf(buf, sizeof buf, "| %s | %d (%d) | %.0f | %.0f | %.2f |\n", CaseName(r.which),
                    j + 1, r.story[j], r.peak_force_each_n[j], r.rms_force_each_n[j],
                    r.mean_voltage_each[j]);
      out << buf;
    }
  }
  return out.str();
}

}  // namespace mrd::structure
