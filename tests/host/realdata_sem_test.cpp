// Issue 5: identification on the measured NEES-2012-1158 run, end to end through the CLI
// (import -> slice -> identify with host/specs/nees.toml -> simulate on held-out data).
// About 2 s: identification on 14 s at 1 kHz.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "mrd/host/model_file.hpp"
#include "simulate_json.hpp"
#include "test_util.hpp"

namespace mrd::test {
namespace {

TEST(RealDataSemTest, NeesSpecFitsHeldOutSegment) {
  ASSERT_TRUE(std::filesystem::exists(kNeesFile)) << "missing shipped data: " << kNeesFile;
  TempDir dir;
  const std::string all = dir.File("nees.csv"), id = dir.File("id.csv"),
                    held = dir.File("held.csv"), model = dir.File("nees.json");
  auto ok = [](const CommandResult& r) { ASSERT_EQ(r.status, 0) << r.output; };
  ok(test::Run(Bin("mrd") + " import --in " + kNeesFile +
               " --map t=t,x=D,v=V,E=Y,f=F --rate 1000 --out " + all));
  // Identification 0 ... 14 s; held out 14 ... 19.5 s. The last 0.5 s (the rig on its end
  // stop: x pinned at 1.08 cm, |v| to 78 cm/s, f to 4.6 kN) is outside the damper's operating
  // range and in neither segment.
  ok(test::Run(Bin("mrd") + " slice --in " + all + " --from 0 --to 14 --out " + id));
  ok(test::Run(Bin("mrd") + " slice --in " + all + " --from 14 --to 19.5 --out " + held));
  ok(test::Run(Bin("mrd") + " identify --data " + id + " --spec " + MRD_SOURCE_DIR +
               "/host/specs/nees.toml --threads 2 --out " + model));

  // The pick is invertible in E over its identification envelope (spec monotone_in), and on
  // the held-out data's states too.
  const host::ModelFile mf = host::LoadModelFile(model);
  ASSERT_TRUE(mf.invertibility.recorded);
  EXPECT_EQ(mf.invertibility.failing, 0u) << mf.invertibility.summary;
  EXPECT_GT(mf.invertibility.states, 10000u);
  const auto h = SimulateJson(model, held);
  ASSERT_FALSE(h["diverged"].get<bool>());
  EXPECT_TRUE(h["invertibility"]["pass"].get<bool>()) << h["invertibility"].dump();
  // Measured 91.0 % (docs/results.md); the Spencer 1997 model reaches about 51 % on this run.
  EXPECT_GE(h["fit_percent"].get<double>(), 90.0);
  EXPECT_LE(h["rrse"].get<double>(), 0.10);
  // No sign of over-fitting: the held-out fit is within 2 points of the identification fit.
  const auto i = SimulateJson(model, id);
  EXPECT_LT(i["fit_percent"].get<double>() - h["fit_percent"].get<double>(), 2.0);

  // The identified model (low-pass command regressor) is accepted by the table exporter,
  // which applies the firmware's checks (inverter included).
  ok(test::Run(Bin("mrd") + " export --model " + model + " --table " + dir.File("nees.bin") +
               " --header " + dir.File("nees.hpp")));
  ok(test::Run(Bin("mrd-firmware") + " --table " + dir.File("nees.bin") +
               " --dry-run 0.5 --lockstep"));
}

}  // namespace
}  // namespace mrd::test
