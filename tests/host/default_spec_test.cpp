// `mrd identify` without --spec: the built-in copies of host/specs/paper-saturating.toml and
// host/specs/nees.toml (host/include/mrd/host/default_spec.hpp), each identified and the one with
// the lowest cross-validated RMSE kept (sem_default.hpp); --help says so.
#include "mrd/host/default_spec.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem_default.hpp"
#include "sem_test_util.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

const std::string kSpecs = std::string(MRD_SOURCE_DIR) + "/host/specs/";

TEST(DefaultSpecTest, BuiltInTextsAreTheShippedSpecs) {
  const auto specs = BuiltInSemSpecs();
  ASSERT_EQ(specs.size(), 2u);
  const char* files[] = {"paper-saturating.toml", "nees.toml"};
  for (std::size_t i = 0; i < specs.size(); ++i) {
    SCOPED_TRACE(files[i]);
    const std::string shipped = test::FileBytes(kSpecs + files[i]);
    ASSERT_FALSE(shipped.empty());
    EXPECT_EQ(std::string(specs[i].text), shipped);
    EXPECT_EQ(std::string(specs[i].name), std::string(files[i]) + " (built in)");
    const SemSpec s = ParseSemSpec(specs[i].text, specs[i].name);
    EXPECT_EQ(s.output, "f");
    EXPECT_EQ(s.monotone_in, "E");  // every built-in pick is invertible in E
    EXPECT_TRUE(s.stress.enabled);
  }
}

TEST(DefaultSpecTest, HelpNamesTheDefault) {
  const auto r = test::Run(test::Bin("mrd") + " identify --help");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto at = r.output.find("--spec");
  ASSERT_NE(at, std::string::npos) << r.output;
  EXPECT_NE(r.output.find("default: the built-in", at), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("paper-saturating.toml", at), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("nees.toml", at), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("REQUIRED", at), r.output.find("REQUIRED", r.output.find("--out")))
      << "--spec must not be required:\n"
      << r.output;
}

// Identified without --spec from another working directory (nothing of the source tree at
// hand): both built-in specs run, the output and the model file say which was kept and why, and
// the model holds that spec as parsed from its shipped file.
TEST(DefaultSpecTest, IdentifyWithoutSpecKeepsTheBuiltInSpecOfLowestRmse) {
  test::TempDir dir;
  const DataSet d = test::DamperData("v1", 1200);
  WriteCsv(dir.File("id.csv"), d.names, d.columns);
  const auto r = test::Run("cd " + dir.File("") + " && " + test::Bin("mrd") +
                           " identify --data id.csv --out m.json --max-iterations 2 --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("built-in spec 1/2: paper-saturating.toml (built in)"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("built-in spec 2/2: nees.toml (built in)"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("20-fold cross-validated free-run RMSE"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("<- chosen"), std::string::npos) << r.output;
  const ModelFile mf = LoadModelFile(dir.File("m.json"));
  const SpecChoice& c = mf.spec_choice;
  ASSERT_EQ(c.specs.size(), 2u);
  ASSERT_GE(c.chosen, 0);
  for (const SpecCandidate& s : c.specs) {
    EXPECT_TRUE(std::isfinite(s.rmse)) << s.name;
    EXPECT_GT(s.rmse, 0.0) << s.name;
    EXPECT_LE(c.specs[static_cast<std::size_t>(c.chosen)].rmse, s.rmse) << s.name;
  }
  const std::string file = c.chosen == 0 ? "paper-saturating.toml" : "nees.toml";
  EXPECT_EQ(c.specs[static_cast<std::size_t>(c.chosen)].name, file + " (built in)");
  const SemSpec want = LoadSemSpec(kSpecs + file);
  ASSERT_EQ(mf.spec.regressors.size(), want.regressors.size());
  for (std::size_t i = 0; i < want.regressors.size(); ++i) {
    EXPECT_EQ(mf.spec.regressors[i].name, want.regressors[i].name);
    EXPECT_EQ(mf.spec.regressors[i].transform, want.regressors[i].transform);
    EXPECT_EQ(mf.spec.regressors[i].powers, want.regressors[i].powers);
    EXPECT_EQ(mf.spec.regressors[i].delays, want.regressors[i].delays);
  }
  EXPECT_EQ(mf.spec.weighting, want.weighting);
  EXPECT_EQ(mf.spec.strategy, want.strategy);
}

// With --spec nothing is chosen: no spec_choice in the model file.
TEST(DefaultSpecTest, AGivenSpecIsNotChosenAmongOthers) {
  test::TempDir dir;
  const DataSet d = test::DamperData("v1", 1200);
  WriteCsv(dir.File("id.csv"), d.names, d.columns);
  const auto r =
      test::Run(test::Bin("mrd") + " identify --data " + dir.File("id.csv") + " --spec " + kSpecs +
                "paper.toml --out " + dir.File("m.json") + " --max-iterations 1 --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("built-in spec"), std::string::npos) << r.output;
  EXPECT_TRUE(LoadModelFile(dir.File("m.json")).spec_choice.empty());
}

// The model file's spec_choice section: round trip, and a damaged one refused with the file.
TEST(DefaultSpecTest, SpecChoiceSectionRoundTripsAndBadOnesAreRefused) {
  SpecChoice c;
  c.rule = "lowest RMSE";
  c.specs = {{"a.toml (built in)", 41.5, 12, 10},
             {"b.toml (built in)", std::numeric_limits<double>::infinity(), 3, 3}};
  c.chosen = 0;
  const nlohmann::json j = SpecChoiceToJson(c);
  EXPECT_TRUE(j["specs"][1]["rmse"].is_null());
  const SpecChoice back = SpecChoiceFromJson(j, "m.json");
  EXPECT_EQ(back.rule, c.rule);
  EXPECT_EQ(back.chosen, 0);
  ASSERT_EQ(back.specs.size(), 2u);
  EXPECT_EQ(back.specs[0].name, c.specs[0].name);
  EXPECT_EQ(back.specs[0].rmse, 41.5);
  EXPECT_TRUE(std::isinf(back.specs[1].rmse));
  EXPECT_EQ(back.specs[0].terms, 10u);
  auto refused = [](nlohmann::json bad, const std::string& want) {
    try {
      SpecChoiceFromJson(bad, "m.json");
      ADD_FAILURE() << "accepted: " << bad.dump();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("m.json"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  nlohmann::json bad = j;
  bad["chosen"] = 2;
  refused(bad, "'chosen'");
  bad = j;
  bad["specs"][0].erase("rmse");
  refused(bad, "lacks 'rmse'");
  bad = j;
  bad["specs"][0]["terms"] = 1.5;
  refused(bad, "counts");
  bad = j;
  bad["specs"] = nlohmann::json::array();
  refused(bad, "non-empty");
}

// Data without the spec's columns: a clear refusal naming the missing column, exit 2.
TEST(DefaultSpecTest, DataWithoutTheDamperColumnsIsRefused) {
  test::TempDir dir;
  WriteCsv(dir.File("toy.csv"), {"t", "u", "y"},
           {{0.0, 0.1, 0.2}, {1.0, 2.0, 3.0}, {0.0, 1.0, 2.0}});
  const auto r = test::Run(test::Bin("mrd") + " identify --data " + dir.File("toy.csv") +
                           " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("'f'"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("m.json")));
}

}  // namespace
}  // namespace mrd::host
