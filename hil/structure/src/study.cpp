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

  Response r;
  r.which = which;
  hil::StructureMetrics metrics;  // the harness's accumulation (structure_scores.hpp)
  double sum_e = 0.0;
  ShearFrameSample s = frame.sample();
  for (long k = 0; k < steps; ++k) {
    double E = e_const;
    if (which == Case::kClippedOptimal) {
      firmware::Real accel[3];
      for (int i = 0; i < 3; ++i) accel[i] = static_cast<firmware::Real>(s.xa[i]);
      E = static_cast<double>(law.Update(accel, static_cast<firmware::Real>(s.force)));
    }
    sum_e += E;
    const double t0 = static_cast<double>(k) * T;
    s = frame.Step(T, ag_at(t0), ag_at(t0 + T), E);
    metrics.Add(s);
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
  return out.str();
}

}  // namespace mrd::structure
