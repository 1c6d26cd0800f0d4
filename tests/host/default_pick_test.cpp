// `mrd identify` without --spec against every shipped spec, judged by the free-run fit on data
// the models were not fitted on: the measured NEES run (held-out segment) and three generated
// dampers other than the reference one, with force noise (held-out run of the same excitation
// design, another seed). The default must come within kPoints of the best shipped spec, and its
// pick must be invertible in E over its identification envelope.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "mrd/host/model_file.hpp"
#include "simulate_json.hpp"
#include "test_util.hpp"

namespace mrd::test {
namespace {

constexpr double kPoints = 2.0;  // [% of fit] the default may trail the best shipped spec by
const char* const kShipped[] = {"paper", "paper-saturating", "nees", "nees-family"};

// Identifies `id` with each shipped spec and without --spec; returns the held-out fits.
void ExpectDefaultNearTheBest(const TempDir& dir, const std::string& id, const std::string& held) {
  auto fit_of = [&](const std::string& name, const std::string& spec_arg) {
    const std::string model = dir.File(name + ".json");
    const auto r =
        test::Run(Bin("mrd") + " identify --data " + id + spec_arg + " --threads 2 --out " + model);
    EXPECT_EQ(r.status, 0) << r.output;
    const auto j = SimulateJson(model, held);
    EXPECT_FALSE(j["diverged"].get<bool>()) << name;
    return j["fit_percent"].is_number() ? j["fit_percent"].get<double>() : -1e9;
  };
  double best = -1e9;
  std::string best_name;
  std::string fits;
  for (const char* s : kShipped) {
    const double f =
        fit_of(s, std::string(" --spec ") + MRD_SOURCE_DIR + "/host/specs/" + s + ".toml");
    fits += std::string(s) + " " + std::to_string(f) + " %; ";
    if (f > best) best = f, best_name = s;
  }
  const double def = fit_of("default", "");
  EXPECT_GE(def, best - kPoints) << "default " << def << " %; " << fits;
  const host::ModelFile mf = host::LoadModelFile(dir.File("default.json"));
  ASSERT_EQ(mf.spec_choice.specs.size(), 2u);
  ASSERT_TRUE(mf.invertibility.recorded);
  EXPECT_EQ(mf.invertibility.failing, 0u) << mf.invertibility.summary;
  std::cout << "held-out fit: default " << def << " %; " << fits << "best " << best_name << "\n";
}

TEST(DefaultPickTest, NeesRunWithinTwoPointsOfTheBestShippedSpec) {
  ASSERT_TRUE(std::filesystem::exists(kNeesFile)) << "missing shipped data: " << kNeesFile;
  TempDir dir;
  const std::string all = dir.File("nees.csv"), id = dir.File("id.csv"),
                    held = dir.File("held.csv");
  auto ok = [](const CommandResult& r) { ASSERT_EQ(r.status, 0) << r.output; };
  ok(test::Run(Bin("mrd") + " import --in " + kNeesFile +
               " --map t=t,x=D,v=V,E=Y,f=F --rate 1000 --out " + all));
  ok(test::Run(Bin("mrd") + " slice --in " + all + " --from 0 --to 14 --out " + id));
  ok(test::Run(Bin("mrd") + " slice --in " + all + " --from 14 --to 19.5 --out " + held));
  ExpectDefaultNearTheBest(dir, id, held);
}

struct Damper {
  const char* name;
  std::string params;  // mrd generate's damper option
  double noise;        // [N]
};
void PrintTo(const Damper& d, std::ostream* os) { *os << d.name; }

class DefaultPickGeneratedTest : public testing::TestWithParam<Damper> {};

TEST_P(DefaultPickGeneratedTest, WithinTwoPointsOfTheBestShippedSpec) {
  const Damper& d = GetParam();
  TempDir dir;
  const std::string all = dir.File("all.csv"), id = dir.File("id.csv"), held = dir.File("held.csv");
  auto ok = [](const CommandResult& r) { ASSERT_EQ(r.status, 0) << r.output; };
  const std::string gen = Bin("mrd") + " generate --profile identification " + d.params +
                          " --noise " + std::to_string(d.noise);
  ok(test::Run(gen + " --seed 2 --out " + all));
  ok(test::Run(Bin("mrd") + " slice --in " + all + " --from 0 --to 20 --out " + id));  // 20 s
  ok(test::Run(gen + " --seed 5 --out " + held));
  ExpectDefaultNearTheBest(dir, id, held);
}

const std::string kDampers = std::string(MRD_SOURCE_DIR) + "/tests/data/dampers/";
INSTANTIATE_TEST_SUITE_P(
    Dampers, DefaultPickGeneratedTest,
    testing::Values(Damper{"spencer1997", "--preset spencer1997", 10.0},
                    Damper{"stiff", "--params " + kDampers + "stiff.toml", 20.0},
                    Damper{"soft", "--params " + kDampers + "soft.toml", 5.0}),
    [](const testing::TestParamInfo<Damper>& i) { return std::string(i.param.name); });

}  // namespace
}  // namespace mrd::test
