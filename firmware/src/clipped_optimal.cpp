#include "mrd/firmware/clipped_optimal.hpp"

#include <cmath>
#include <cstddef>

namespace mrd::firmware {

namespace {

template <std::size_t N>
bool AllFinite(const double (&a)[N]) {
  for (double v : a) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

template <std::size_t N>
void ToReal(const double (&in)[N], Real (&out)[N]) {
  for (std::size_t i = 0; i < N; ++i) out[i] = static_cast<Real>(in[i]);
}

}  // namespace

bool ClippedOptimalGains::IsValid(const char** reason) const {
  const char* bad = nullptr;
  if (!AllFinite(ad))
    bad = "ad";
  else if (!AllFinite(bd))
    bad = "bd";
  else if (!AllFinite(cy))
    bad = "cy";
  else if (!AllFinite(dy))
    bad = "dy";
  else if (!AllFinite(l))
    bad = "l";
  else if (!AllFinite(k))
    bad = "k";
  else if (dampers < 1 || dampers > kMaxDampers)
    bad = "dampers";
  else if (!std::isfinite(v_max) || !std::isfinite(v_min) || v_min > v_max)
    bad = "v_max";
  if (bad != nullptr && reason != nullptr) *reason = bad;
  return bad == nullptr;
}

Real ClippedRule(Real fc, Real f, Real v_max, Real v_min) {
  return ((fc - f) * f > Real(0)) ? v_max : v_min;
}

void ClippedOptimal::Configure(const ClippedOptimalGains& gains) {
  m_ = (gains.dampers >= 1 && gains.dampers <= kMaxDampers) ? gains.dampers : 1;
  ToReal(gains.ad, ad_);
  ToReal(gains.bd, bd_);
  ToReal(gains.cy, cy_);
  ToReal(gains.dy, dy_);
  ToReal(gains.l, l_);
  ToReal(gains.k, k_);
  v_max_ = static_cast<Real>(gains.v_max);
  v_min_ = static_cast<Real>(gains.v_min);
  Reset();
}

void ClippedOptimal::Reset() {
  for (Real& x : xh_) x = Real(0);
  for (Real& f : fc_) f = Real(0);
}

void ClippedOptimal::Update(const Real* accel, const Real* force, Real* volts) {
  const int m = m_;
  for (int j = 0; j < m; ++j) {
    Real fc = Real(0);
    for (int i = 0; i < kStates; ++i) fc -= k_[j * kStates + i] * xh_[i];
    fc_[j] = fc;
  }
  Real innovation[kOutputs];
  for (int r = 0; r < kOutputs; ++r) {
    Real predicted = dy_[r * m] * force[0];
    for (int j = 1; j < m; ++j) predicted += dy_[r * m + j] * force[j];
    for (int c = 0; c < kStates; ++c) predicted += cy_[r * kStates + c] * xh_[c];
    innovation[r] = accel[r] - predicted;
  }
  Real next[kStates];
  for (int r = 0; r < kStates; ++r) {
    Real v = bd_[r * m] * force[0];
    for (int j = 1; j < m; ++j) v += bd_[r * m + j] * force[j];
    for (int c = 0; c < kStates; ++c) v += ad_[r * kStates + c] * xh_[c];
    for (int c = 0; c < kOutputs; ++c) v += l_[r * kOutputs + c] * innovation[c];
    next[r] = v;
  }
  for (int i = 0; i < kStates; ++i) xh_[i] = next[i];
  for (int j = 0; j < m; ++j) volts[j] = ClippedRule(fc_[j], force[j], v_max_, v_min_);
}

Real ClippedOptimal::Update(const Real* accel, Real force) {
  Real forces[kMaxDampers] = {force};
  Real volts[kMaxDampers] = {};
  Update(accel, forces, volts);
  return volts[0];
}

}  // namespace mrd::firmware
