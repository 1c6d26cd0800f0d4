// `mrd identify` without --spec: the built-in copy of host/specs/paper-saturating.toml
// (host/include/mrd/host/default_spec.hpp), and --help says so.
#include "mrd/host/default_spec.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/model_file.hpp"
#include "sem_test_util.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

const std::string kSpecFile = std::string(MRD_SOURCE_DIR) + "/host/specs/paper-saturating.toml";

TEST(DefaultSpecTest, BuiltInTextIsTheShippedSaturatingSpec) {
  const std::string shipped = test::FileBytes(kSpecFile);
  ASSERT_FALSE(shipped.empty()) << kSpecFile;
  EXPECT_EQ(std::string(DefaultSemSpecText()), shipped);
  const SemSpec s = ParseSemSpec(DefaultSemSpecText(), kDefaultSemSpecName);
  EXPECT_EQ(s.output, "f");
  ASSERT_GE(s.RegressorIndex("w"), 0);
  EXPECT_EQ(s.regressors[static_cast<std::size_t>(s.RegressorIndex("w"))].transform,
            Transform::kTanh);
  EXPECT_TRUE(s.stress.enabled);
}

TEST(DefaultSpecTest, HelpNamesTheDefault) {
  const auto r = test::Run(test::Bin("mrd") + " identify --help");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto at = r.output.find("--spec");
  ASSERT_NE(at, std::string::npos) << r.output;
  EXPECT_NE(r.output.find("default: the built-in", at), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("paper-saturating.toml", at), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("REQUIRED", at), r.output.find("REQUIRED", r.output.find("--out")))
      << "--spec must not be required:\n"
      << r.output;
}

// Identified without --spec from another working directory (nothing of the source tree at
// hand): the model file holds the saturating spec, as parsed from the shipped file.
TEST(DefaultSpecTest, IdentifyWithoutSpecUsesTheSaturatingSpec) {
  test::TempDir dir;
  const DataSet d = test::DamperData("v1", 1200);
  WriteCsv(dir.File("id.csv"), d.names, d.columns);
  const auto r = test::Run("cd " + dir.File("") + " && " + test::Bin("mrd") +
                           " identify --data id.csv --out m.json --max-iterations 1 --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("stress"), std::string::npos) << r.output;  // [stress] of the spec
  const ModelFile mf = LoadModelFile(dir.File("m.json"));
  const SemSpec want = LoadSemSpec(kSpecFile);
  ASSERT_EQ(mf.spec.regressors.size(), want.regressors.size());
  for (std::size_t i = 0; i < want.regressors.size(); ++i) {
    EXPECT_EQ(mf.spec.regressors[i].name, want.regressors[i].name);
    EXPECT_EQ(mf.spec.regressors[i].transform, want.regressors[i].transform);
    EXPECT_EQ(mf.spec.regressors[i].powers, want.regressors[i].powers);
    EXPECT_EQ(mf.spec.regressors[i].delays, want.regressors[i].delays);
  }
  EXPECT_EQ(mf.spec.strategy, want.strategy);
  // The spec's algorithm: one_step_start = false, exchange at its default (on).
  EXPECT_NE(r.output.find("second start off"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("exchange moves off"), std::string::npos) << r.output;
}

// Data without the spec's columns: a clear refusal naming the built-in spec, exit 2.
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
