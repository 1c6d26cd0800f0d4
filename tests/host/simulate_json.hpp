#pragma once
// `mrd simulate --json` of a model on a data set, parsed (the test fails on a non-zero exit),
// and the shipped NEES run the real-data tests import.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "test_util.hpp"

namespace mrd::test {

inline const std::string kNeesFile =
    std::string(MRD_SOURCE_DIR) + "/tests/data/nees-2012-1158/ransim_u.csv";

inline nlohmann::json SimulateJson(const std::string& model, const std::string& data) {
  const auto r = Run(Bin("mrd") + " simulate --model " + model + " --data " + data + " --json");
  EXPECT_EQ(r.status, 0) << r.output;
  return nlohmann::json::parse(r.output.substr(r.output.find('{')));
}

}  // namespace mrd::test
