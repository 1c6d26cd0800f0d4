// Issue 15 on the shipped NEES-2012-1158 run: host/specs/nees-family.toml (nees.toml with the
// velocity regressor u2 a transform family: abs_pow 0.2 / 0.5, tanh 0.05 / 0.1 / 0.2)
// identified by the same steps as realdata_sem_test.cpp (identify on 0-14 s, free run on
// 14-19.5 s). About 50 s: five identifications of 14 s at 1 kHz.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "mrd/host/model_file.hpp"
#include "simulate_json.hpp"
#include "test_util.hpp"

namespace mrd::test {
namespace {

TEST(RealDataFamilyTest, NeesFamilyChoosesByCrossValidationAndFitsHeldOutSegment) {
  ASSERT_TRUE(std::filesystem::exists(kNeesFile)) << "missing shipped data: " << kNeesFile;
  TempDir dir;
  const std::string all = dir.File("nees.csv"), id = dir.File("id.csv"),
                    held = dir.File("held.csv"), model = dir.File("family.json");
  auto ok = [](const CommandResult& r) { ASSERT_EQ(r.status, 0) << r.output; };
  ok(test::Run(Bin("mrd") + " import --in " + kNeesFile +
               " --map t=t,x=D,v=V,E=Y,f=F --rate 1000 --out " + all));
  ok(test::Run(Bin("mrd") + " slice --in " + all + " --from 0 --to 14 --out " + id));
  ok(test::Run(Bin("mrd") + " slice --in " + all + " --from 14 --to 19.5 --out " + held));
  const auto r = test::Run(Bin("mrd") + " identify --data " + id + " --spec " + MRD_SOURCE_DIR +
                           "/host/specs/nees-family.toml --threads 2 --out " + model);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("family 5/5: u2 = tanh(scale=0.2)"), std::string::npos) << r.output;
  const host::ModelFile mf = host::LoadModelFile(model);
  const auto& f = mf.family;
  ASSERT_EQ(f.combinations.size(), 5u);
  EXPECT_EQ(f.regressors, std::vector<std::string>{"u2"});
  double lowest = f.combinations[0].score;
  for (const auto& c : f.combinations) {
    EXPECT_TRUE(std::isfinite(c.score));
    lowest = std::min(lowest, c.score);
  }
  EXPECT_EQ(f.combinations[static_cast<std::size_t>(f.chosen)].score, lowest);
  // The model file's spec holds the chosen member.
  const auto& u2 = mf.spec.regressors[static_cast<std::size_t>(mf.spec.RegressorIndex("u2"))];
  EXPECT_EQ(u2.transform, f.combinations[static_cast<std::size_t>(f.chosen)].members[0].transform);
  // The pick is invertible in E over its identification envelope (spec monotone_in).
  ASSERT_TRUE(mf.invertibility.recorded);
  EXPECT_EQ(mf.invertibility.failing, 0u) << mf.invertibility.summary;
  EXPECT_GT(mf.invertibility.states, 10000u);
  // Held-out fit: the bar of realdata_sem_test (measured 90.9 %, docs/results.md).
  const auto h = SimulateJson(model, held);
  ASSERT_FALSE(h["diverged"].get<bool>());
  EXPECT_GE(h["fit_percent"].get<double>(), 90.0);
  EXPECT_LE(h["rrse"].get<double>(), 0.10);
  const auto i = SimulateJson(model, id);
  EXPECT_LT(i["fit_percent"].get<double>() - h["fit_percent"].get<double>(), 2.0);
  // Table export (the firmware's checks, inverter included) and the firmware run it as any.
  ok(test::Run(Bin("mrd") + " export --model " + model + " --table " + dir.File("f.bin") +
               " --header " + dir.File("f.hpp")));
  ok(test::Run(Bin("mrd-firmware") + " --table " + dir.File("f.bin") +
               " --dry-run 0.5 --lockstep"));
}

}  // namespace
}  // namespace mrd::test
