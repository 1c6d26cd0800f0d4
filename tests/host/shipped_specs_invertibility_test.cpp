// The demo's identification (host/specs/paper.toml on the generated reference sets, as
// toolchain/demo.sh runs it) and the saturating spec on the same data pick models that are
// invertible in E over their identification envelope: the model file records 0 failing
// states, `mrd simulate` on the identification data agrees, and `mrd export` takes the model
// without --allow-non-monotone and records the check in the table. (The NEES specs on the
// measured run: realdata_sem_test.cpp, realdata_family_test.cpp.)
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "mrd/common/table.hpp"
#include "mrd/host/model_file.hpp"
#include "simulate_json.hpp"
#include "test_util.hpp"

namespace mrd::test {
namespace {

class ShippedSpecInvertibilityTest : public ::testing::TestWithParam<const char*> {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    for (const char* p : {"identification", "v1", "v2", "v3"}) {
      const auto r = mrd::test::Run(Bin("mrd") + " generate --profile " + p + " --seed 1 --out " +
                                    dir_->File(std::string(p) + ".csv"));
      ASSERT_EQ(r.status, 0) << r.output;
    }
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static TempDir* dir_;
};
TempDir* ShippedSpecInvertibilityTest::dir_ = nullptr;

TEST_P(ShippedSpecInvertibilityTest, PickIsInvertibleAndExports) {
  const std::string spec = GetParam();
  const std::string model = dir_->File(spec + ".json");
  const std::string val =
      dir_->File("v1.csv") + "," + dir_->File("v2.csv") + "," + dir_->File("v3.csv");
  const auto r = mrd::test::Run(
      Bin("mrd") + " identify --data " + dir_->File("identification.csv") + " --validate " + val +
      " --spec " + MRD_SOURCE_DIR + "/host/specs/" + spec + ".toml --threads 2 --out " + model);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("invertibility in E on ["), std::string::npos) << r.output;
  const host::ModelFile mf = host::LoadModelFile(model);
  EXPECT_EQ(mf.spec.monotone_in, "E");  // on in every shipped spec
  ASSERT_TRUE(mf.invertibility.recorded);
  EXPECT_EQ(mf.invertibility.iteration, mf.selected);
  EXPECT_EQ(mf.invertibility.failing, 0u) << mf.invertibility.summary;
  EXPECT_GT(mf.invertibility.states, 10000u);
  EXPECT_EQ(mf.invertibility.share_percent, 0.0);
  // `mrd simulate` on the identification data checks the same states: the same verdict.
  // (On validation data the states differ: V2's reversals at the velocity's edge may fail a
  // few, which is reported, not required here.)
  const auto j = SimulateJson(model, dir_->File("identification.csv"));
  EXPECT_TRUE(j["invertibility"]["pass"].get<bool>()) << j["invertibility"].dump();
  EXPECT_EQ(j["invertibility"]["states"].get<std::size_t>(), mf.invertibility.states);
  const std::string table = dir_->File(spec + ".bin");
  const auto e = mrd::test::Run(Bin("mrd") + " export --model " + model + " --table " + table);
  ASSERT_EQ(e.status, 0) << e.output;
  EXPECT_EQ(e.output.find("not invertible"), std::string::npos) << e.output;
  const std::string bytes = FileBytes(table);
  const auto d =
      DecodeTable(std::span(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
  ASSERT_TRUE(d.ok()) << ErrorName(d.error());
  EXPECT_TRUE(d.value().has_invertibility);
  EXPECT_GT(d.value().invertibility.states, 10000u);
  EXPECT_EQ(d.value().invertibility.failing, 0u);
  EXPECT_TRUE(std::isfinite(d.value().invertibility.worst_slope));  // within the flat tolerance
}

INSTANTIATE_TEST_SUITE_P(Specs, ShippedSpecInvertibilityTest,
                         ::testing::Values("paper", "paper-saturating"),
                         [](const ::testing::TestParamInfo<const char*>& p) {
                           std::string n = p.param;
                           for (char& c : n) {
                             if (c == '-') c = '_';
                           }
                           return n;
                         });

}  // namespace
}  // namespace mrd::test
