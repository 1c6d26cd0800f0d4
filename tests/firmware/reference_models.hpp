#pragma once
// Small hand-written models for the firmware tests (besides support/demo_model.hpp).

#include <cstring>
#include <initializer_list>

#include "mrd/common/table.hpp"

namespace mrd::test {

// Channels 0 = v, 1 = E, 2 = f. Regressors 0 = f, 1 = E, 2 = |v|^0.2, 3 = sign(v), 4 = v.
// No terms; add them with AddTerm.
inline CoefficientTable EmptyTable() {
  CoefficientTable t;
  Model& m = t.model;
  m.num_channels = 3;
  m.output_channel = 2;
  std::strcpy(m.channel_names[0].data(), "v");
  std::strcpy(m.channel_names[1].data(), "E");
  std::strcpy(m.channel_names[2].data(), "f");
  m.scales[0] = {0.0, 15.0};
  m.scales[1] = {0.0, 2.25};
  m.scales[2] = {0.0, 1500.0};
  m.num_regressors = 5;
  m.regressors[0] = {2, Transform::kIdentity, 1.0};
  m.regressors[1] = {1, Transform::kIdentity, 1.0};
  m.regressors[2] = {0, Transform::kAbsPow, 0.2};
  m.regressors[3] = {0, Transform::kSign, 1.0};
  m.regressors[4] = {0, Transform::kIdentity, 1.0};
  t.input_channel = 1;
  t.e_min = 0.0;
  t.e_max = 2.25;
  return t;
}

inline void AddTerm(CoefficientTable& t, std::initializer_list<Factor> factors, double theta) {
  Model& m = t.model;
  Term& term = m.terms[m.num_terms];
  term.num_factors = static_cast<std::uint8_t>(factors.size());
  std::size_t j = 0;
  for (const Factor& f : factors) term.factors[j++] = f;
  m.coefficients[m.num_terms++] = theta;
}

// Degree-4 model in E with state-dependent coefficients (non-monotone in E for some states).
inline CoefficientTable QuarticTable() {
  CoefficientTable t = EmptyTable();
  AddTerm(t, {{0, 1, 1}}, 0.8);
  AddTerm(t, {{3, 0, 1}}, 0.05);
  AddTerm(t, {{1, 0, 1}, {2, 0, 1}, {3, 0, 1}}, 0.3);
  AddTerm(t, {{1, 0, 2}, {4, 0, 1}}, -0.4);
  AddTerm(t, {{1, 0, 3}, {0, 1, 1}}, 0.5);
  AddTerm(t, {{1, 0, 4}, {3, 1, 1}}, 0.2);
  AddTerm(t, {{1, 0, 1}, {1, 0, 1}}, 0.05);  // E(k) twice: degree 2 from two factors
  return t;
}

// Monotone in E on [0, 2.25] V for every state with v != 0 (direction by sign(v)):
// f(k) = 0.85 f(k-1) + 0.03 sign(v) + sign(v) (0.08 E |v|^0.2 + 0.02 E^3).
inline CoefficientTable MonotoneTable() {
  CoefficientTable t = EmptyTable();
  AddTerm(t, {{0, 1, 1}}, 0.85);
  AddTerm(t, {{3, 0, 1}}, 0.03);
  AddTerm(t, {{1, 0, 1}, {2, 0, 1}, {3, 0, 1}}, 0.08);
  AddTerm(t, {{1, 0, 3}, {3, 0, 1}}, 0.02);
  return t;
}

// Not monotone in E where |v| > 6 cm/s (0.4 of the 15 cm/s scale), with e = E / 2.25 V:
// y(k) = 0.6 y(k-1) + sign(v) (0.05 + 0.4 e) - 0.5 (v / 15) e^2, so dy/de = sign(v)
// (0.4 - |v / 15| e): the force peaks at e = 0.4 / |v / 15| and falls beyond it, and at
// |v| = 15 cm/s the stiff end gives less force than the soft one (a fit's artefact a real damper
// does not have).
inline CoefficientTable NonMonotoneTable() {
  CoefficientTable t = EmptyTable();
  AddTerm(t, {{0, 1, 1}}, 0.6);
  AddTerm(t, {{3, 0, 1}}, 0.05);
  AddTerm(t, {{1, 0, 1}, {3, 0, 1}}, 0.4);
  AddTerm(t, {{1, 0, 2}, {4, 0, 1}}, -0.5);
  return t;
}

// Degree-4 model in which E(k) enters both directly and through a first-order low-pass
// (regressor 5, tau 6 samples: affine in E(k) with a state-dependent offset), the form that
// host/specs/nees.toml produces for measured dampers.
inline CoefficientTable LowPassTable() {
  CoefficientTable t = EmptyTable();
  t.model.regressors[t.model.num_regressors++] = {1, Transform::kLowPass, 6.0};
  AddTerm(t, {{0, 1, 1}}, 0.7);
  AddTerm(t, {{5, 0, 1}, {2, 0, 1}, {3, 0, 1}}, 0.9);
  AddTerm(t, {{5, 0, 2}, {1, 0, 1}, {3, 0, 1}}, -0.3);
  AddTerm(t, {{5, 0, 1}, {1, 0, 3}}, 0.1);
  AddTerm(t, {{5, 2, 1}, {0, 1, 1}}, 0.2);  // low-pass at delay 2: history only
  AddTerm(t, {}, 0.01);
  return t;
}

}  // namespace mrd::test
