#pragma once
// A hand-written, plausible MR-damper model for tests and benchmarks (the firmware's compiled-in
// table was generated from it until it became the paper run's model; tests/data/profiles/
// mrd-native-frames.table.bin is its image, the table that frame capture ran on).
// Normalised signals (v / 15 cm/s, E / 2.25 V, f / 1500 N):
//
//   f(k) = 0.85 f(k-1) - 0.02 f(k-1)^2 + 0.03 sign(v(k)) + 0.02 v(k)
//          + 0.08 E(k) |v(k)|^0.2 sign(v(k)) - 0.02 E(k)^2 sign(v(k)) + 0.01 E(k) sign(v(k-1))
//          + 0.001 E(k)

#include <cstring>

#include "mrd/common/table.hpp"

namespace mrd::test {

// Channels: 0 = v, 1 = E, 2 = f (output).
// Regressors: 0 = f, 1 = E, 2 = |v|^0.2, 3 = sign(v), 4 = v.
inline Model DemoDamperModel() {
  Model m;
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
  auto term = [&m](std::size_t i, std::initializer_list<Factor> factors, double theta) {
    m.terms[i].num_factors = static_cast<std::uint8_t>(factors.size());
    std::size_t j = 0;
    for (const Factor& f : factors) m.terms[i].factors[j++] = f;
    m.coefficients[i] = theta;
  };
  term(0, {{0, 1, 1}}, 0.85);                        // f(k-1)
  term(1, {{0, 1, 2}}, -0.02);                       // f(k-1)^2
  term(2, {{3, 0, 1}}, 0.03);                        // sign(v(k))
  term(3, {{4, 0, 1}}, 0.02);                        // v(k)
  term(4, {{1, 0, 1}, {2, 0, 1}, {3, 0, 1}}, 0.08);  // E(k) |v(k)|^0.2 sign(v(k))
  term(5, {{1, 0, 2}, {3, 0, 1}}, -0.02);            // E(k)^2 sign(v(k))
  term(6, {{1, 0, 1}, {3, 1, 1}}, 0.01);             // E(k) sign(v(k-1))
  term(7, {{1, 0, 1}}, 0.001);                       // E(k)
  m.num_terms = 8;
  return m;
}

// The demo model as a table: input channel E, range 0 ... 2.25 V.
inline CoefficientTable DemoDamperTable() {
  CoefficientTable t;
  t.model = DemoDamperModel();
  t.input_channel = 1;
  t.e_min = 0.0;
  t.e_max = 2.25;
  return t;
}

}  // namespace mrd::test
