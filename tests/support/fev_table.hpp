#pragma once
// A coefficient table's skeleton for hand-built test models: channels f (output, scale
// 1000 N), E (input, 2.25 V) and v (15 cm/s), offsets 0; no regressors or terms yet.
#include <cstddef>

#include "mrd/common/table.hpp"

namespace mrd::test {

inline CoefficientTable FevTableSkeleton() {
  CoefficientTable t;
  Model& m = t.model;
  m.num_channels = 3;
  const char* names[] = {"f", "E", "v"};
  for (std::size_t c = 0; c < 3; ++c) {
    for (std::size_t i = 0; names[c][i] != '\0'; ++i) m.channel_names[c][i] = names[c][i];
  }
  m.scales[0] = {0.0, 1000.0};
  m.scales[1] = {0.0, 2.25};
  m.scales[2] = {0.0, 15.0};
  t.input_channel = 1;
  return t;
}

}  // namespace mrd::test
