#include "mrd/firmware/modal_skyhook.hpp"

#include <cmath>

namespace mrd::firmware {
namespace {

bool Positive(double v) { return std::isfinite(v) && v > 0.0; }
bool NonNegative(double v) { return std::isfinite(v) && v >= 0.0; }

// The first invalid field's description, or nullptr.
const char* Invalid(const BodyGeometry& g, const ModalGains& k) {
  if (!Positive(g.cg_to_front_m)) return "cg_to_front_m must be finite and > 0";
  if (!Positive(g.cg_to_rear_m)) return "cg_to_rear_m must be finite and > 0";
  if (!Positive(g.track_front_m)) return "track_front_m must be finite and > 0";
  if (!Positive(g.track_rear_m)) return "track_rear_m must be finite and > 0";
  if (!Positive(g.motion_ratio) || g.motion_ratio > 1.0) return "motion_ratio must be in (0, 1]";
  if (!NonNegative(k.heave_n_s_per_m)) return "heave gain must be finite and >= 0";
  if (!NonNegative(k.pitch_n_m_s_per_rad)) return "pitch gain must be finite and >= 0";
  if (!NonNegative(k.roll_n_m_s_per_rad)) return "roll gain must be finite and >= 0";
  return nullptr;
}

}  // namespace

Error ModalSkyhook::Configure(const BodyGeometry& g, const ModalGains& k, const char** reason) {
  if (const char* why = Invalid(g, k)) {
    if (reason != nullptr) *reason = why;
    return Error::kOutOfRange;
  }
  const double x[kModalCorners] = {g.cg_to_front_m, g.cg_to_front_m, -g.cg_to_rear_m,
                                   -g.cg_to_rear_m};
  const double y[kModalCorners] = {g.track_front_m / 2, -g.track_front_m / 2, g.track_rear_m / 2,
                                   -g.track_rear_m / 2};
  // N = A^T A (symmetric 3x3), inverted by cofactors; with a, b > 0 and both tracks > 0 the
  // corners are not collinear, so det > 0.
  double n[3][3] = {};
  for (int i = 0; i < kModalCorners; ++i) {
    const double row[3] = {1.0, x[i], y[i]};
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) n[r][c] += row[r] * row[c];
    }
  }
  const double c00 = n[1][1] * n[2][2] - n[1][2] * n[2][1];
  const double c01 = n[1][2] * n[2][0] - n[1][0] * n[2][2];
  const double c02 = n[1][0] * n[2][1] - n[1][1] * n[2][0];
  const double det = n[0][0] * c00 + n[0][1] * c01 + n[0][2] * c02;
  if (!(det > 0.0) || !std::isfinite(det)) {
    if (reason != nullptr) *reason = "the corners do not span heave, pitch and roll";
    return Error::kOutOfRange;
  }
  const double inv[3][3] = {{c00 / det, (n[0][2] * n[2][1] - n[0][1] * n[2][2]) / det,
                             (n[0][1] * n[1][2] - n[0][2] * n[1][1]) / det},
                            {c01 / det, (n[0][0] * n[2][2] - n[0][2] * n[2][0]) / det,
                             (n[0][2] * n[1][0] - n[0][0] * n[1][2]) / det},
                            {c02 / det, (n[0][1] * n[2][0] - n[0][0] * n[2][1]) / det,
                             (n[0][0] * n[1][1] - n[0][1] * n[1][0]) / det}};
  for (int m = 0; m < 3; ++m) {
    for (int i = 0; i < kModalCorners; ++i) {
      fit_[m][i] = static_cast<Real>(inv[m][0] + inv[m][1] * x[i] + inv[m][2] * y[i]);
    }
  }
  gain_[0] = static_cast<Real>(k.heave_n_s_per_m);
  gain_[1] = static_cast<Real>(k.pitch_n_m_s_per_rad);
  gain_[2] = static_cast<Real>(k.roll_n_m_s_per_rad);
  inv_ratio_ = static_cast<Real>(1.0 / g.motion_ratio);
  configured_ = true;
  return Error::kOk;
}

ModalRates ModalSkyhook::Rates(const double* vb_cm_s) const noexcept {
  Real q[3] = {};
  for (int m = 0; m < 3; ++m) {
    for (int i = 0; i < kModalCorners; ++i) {
      q[m] += fit_[m][i] * static_cast<Real>(vb_cm_s[i] / 100.0);
    }
  }
  return {static_cast<double>(q[0]), static_cast<double>(q[1]), static_cast<double>(q[2])};
}

void ModalSkyhook::Demands(const double* vb_cm_s, double* demand_n) const noexcept {
  const ModalRates q = Rates(vb_cm_s);
  // w = -c q on the body; u = fit^T w; f = -u / r = fit^T (c q) / r.
  const Real cq[3] = {gain_[0] * static_cast<Real>(q.heave_m_s),
                      gain_[1] * static_cast<Real>(q.pitch_rad_s),
                      gain_[2] * static_cast<Real>(q.roll_rad_s)};
  for (int i = 0; i < kModalCorners; ++i) {
    Real f = Real(0);
    for (int m = 0; m < 3; ++m) f += fit_[m][i] * cq[m];
    demand_n[i] = configured_ ? static_cast<double>(f * inv_ratio_) : 0.0;
  }
}

}  // namespace mrd::firmware
