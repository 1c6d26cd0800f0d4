// `mrd compare`, `mrd resid`, the range warning of simulate/report/compare/resid and
// `mrd generate --help`, through the executable (labels sem, unit).
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>

#include "judge_fixture.hpp"
#include "mrd/host/plot.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

namespace fs = std::filesystem;

class JudgeCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<test::TempDir>();
    test::WriteArxModel(File("exact.json"), 0.9, 0.05, 0.08);
    test::WriteArxModel(File("off.json"), 0.85, 0.06, 0.1, true);
    test::WriteArxData(File("in1.csv"), 15.0, 0.01, 1);
    test::WriteArxData(File("in2.csv"), 12.0, 0.01, 2);
    test::WriteArxData(File("wide.csv"), 30.0, 0.01, 3);  // v to about 28.6 cm/s
  }
  static void TearDownTestSuite() { dir_.reset(); }
  static std::string File(const std::string& name) { return dir_->File(name); }
  static test::CommandResult Mrd(const std::string& args) {
    return test::Run(test::Bin("mrd") + " " + args);
  }
  // stdout only (stderr to a file).
  static test::CommandResult MrdStdout(const std::string& args, const std::string& err) {
    return test::Run("( " + test::Bin("mrd") + " " + args + " 2>" + err + " )");
  }
  static std::unique_ptr<test::TempDir> dir_;
};
std::unique_ptr<test::TempDir> JudgeCliTest::dir_;

TEST_F(JudgeCliTest, CompareTableOfTwoModelsOnTwoFiles) {
  const test::TempDir out;
  const auto r =
      MrdStdout("compare --model " + File("exact.json") + "," + File("off.json") + " --data " +
                    File("in1.csv") + " --data " + File("in2.csv") + " --json",
                out.File("err.txt"));
  ASSERT_EQ(r.status, 0) << r.output << test::FileBytes(out.File("err.txt"));
  const auto j = nlohmann::json::parse(r.output);
  ASSERT_EQ(j["rows"].size(), 4u);
  // The ARX fixture's force rises with E whatever the sign of v: not invertible where v < 0
  // (about half the states), one warning per model and file and nothing else.
  ASSERT_EQ(j["warnings"].size(), 4u) << j["warnings"].dump();
  for (const auto& w : j["warnings"]) {
    EXPECT_NE(w.get<std::string>().find("invertibility in E"), std::string::npos) << w;
  }
  for (const auto& row : j["rows"]) {
    EXPECT_EQ(row["rmse_unit"], "N");
    EXPECT_FALSE(row["diverged"].get<bool>());
    EXPECT_FALSE(row["outside_envelope"].get<bool>());
    EXPECT_EQ(row["terms"].get<int>(), 3);
    // Each row agrees with `mrd simulate` of that model on that file.
    const auto s = MrdStdout("simulate --json --model " + row["model"].get<std::string>() +
                                 " --data " + row["data"].get<std::string>(),
                             out.File("err2.txt"));
    ASSERT_EQ(s.status, 0) << s.output;
    const auto sj = nlohmann::json::parse(s.output);
    EXPECT_DOUBLE_EQ(row["fit_percent"].get<double>(), sj["fit_percent"].get<double>());
    EXPECT_DOUBLE_EQ(row["rmse"].get<double>(), sj["rmse"].get<double>());
    EXPECT_DOUBLE_EQ(row["nrmse"].get<double>(), 1.0 - row["fit_percent"].get<double>() / 100.0);
  }
  EXPECT_EQ(j["rows"][0]["model"], File("exact.json"));
  EXPECT_EQ(j["rows"][1]["data"], File("in2.csv"));
  EXPECT_EQ(j["rows"][0]["J_weighting"], "unweighted MSE of normalised f");
  EXPECT_EQ(j["rows"][2]["J_weighting"], "relative weighting 1/max(|f_n|, 0.1) of normalised f");
  for (int i : {0, 1}) {  // the exact model fits better than the perturbed one on each file
    EXPECT_GT(j["rows"][i]["fit_percent"].get<double>(),
              j["rows"][i + 2]["fit_percent"].get<double>() + 1.0);
  }

  // Text table: header, four rows naming the weighting, RMSE with its unit.
  const auto t = MrdStdout("compare --model " + File("exact.json") + "," + File("off.json") +
                               " --data " + File("in1.csv") + "," + File("in2.csv"),
                           out.File("err.txt"));
  ASSERT_EQ(t.status, 0) << t.output;
  EXPECT_NE(t.output.find("fit %"), std::string::npos) << t.output;
  EXPECT_NE(t.output.find("J weighting"), std::string::npos) << t.output;
  const std::regex row(
      R"(off\.json\s+\S+in2\.csv\s+[-0-9.]+\s+[0-9.e+]+ N\s+[0-9.]+\s+\S+\s+rel, floor 0\.1\s+3\s+no\s+4[0-9.]+ %\s+-)");
  EXPECT_TRUE(std::regex_search(t.output, row)) << t.output;
}

TEST_F(JudgeCliTest, CompareWritesTableAndOverlayPlots) {
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  const test::TempDir out;
  const auto dir = out.File("cmp");
  const auto r = Mrd("compare --model " + File("exact.json") + "," + File("off.json") + " --data " +
                     File("in1.csv") + "," + File("wide.csv") + " --out " + dir);
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* name : {"in1_compare.png", "wide_compare.png", "compare.txt", "compare.json"}) {
    EXPECT_TRUE(fs::is_regular_file(dir + "/" + name)) << name;
  }
  EXPECT_EQ(test::FileBytes(dir + "/in1_compare.png").compare(0, 4, "\x89PNG"), 0);
  const std::string table = test::FileBytes(dir + "/compare.txt");
  EXPECT_NE(r.output.find(table), std::string::npos);  // the printed table is the file
  EXPECT_EQ(nlohmann::json::parse(test::FileBytes(dir + "/compare.json"))["rows"].size(), 4u);
  // wide.csv is outside both models' envelope in v: two warnings, in the table too; the
  // four others say the ARX fixture is not invertible in E (v < 0) on each model and file.
  std::size_t n = 0, inv = 0;
  std::istringstream lines(r.output);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("warning: ", 0) != 0) continue;
    ++n;
    if (line.find(": invertibility in E") != std::string::npos) ++inv;
  }
  EXPECT_EQ(n, 6u) << r.output;
  EXPECT_EQ(inv, 4u) << r.output;
  EXPECT_NE(table.find("v "), std::string::npos);
  for (const auto& e : fs::directory_iterator(out.File(""))) {
    EXPECT_EQ(e.path().filename().string().find(".compare-"), std::string::npos) << e.path();
  }
}

TEST_F(JudgeCliTest, RangeWarningFiresOutsideTheEnvelopeOnly) {
  const std::regex warn(
      R"(warning: \S+exact\.json on \S+wide\.csv: v outside the identification envelope )"
      R"(\[-15, 15\] cm/s in [0-9.]+ % of samples \(\d+ of 8000\), largest excursion 1[0-9.]+ )"
      R"(cm/s beyond \(v = -?2[0-9.]+ cm/s\))");
  const std::string model = " --model " + File("exact.json");
  for (const std::string cmd : {"simulate", "resid", "compare"}) {
    const auto out = Mrd(cmd + model + " --data " + File("wide.csv"));
    ASSERT_EQ(out.status, 0) << cmd << ": " << out.output;
    EXPECT_TRUE(std::regex_search(out.output, warn)) << cmd << ": " << out.output;
    EXPECT_EQ(out.output.find("E outside"), std::string::npos) << out.output;
    const auto in = Mrd(cmd + model + " --data " + File("in1.csv"));
    ASSERT_EQ(in.status, 0) << cmd << ": " << in.output;
    // No range warning inside the envelope (the fixture's invertibility warning aside).
    EXPECT_EQ(in.output.find("outside the identification envelope"), std::string::npos)
        << cmd << ": " << in.output;
  }
  // In --json too.
  const test::TempDir tmp;
  const auto j =
      MrdStdout("simulate --json" + model + " --data " + File("wide.csv"), tmp.File("err.txt"));
  ASSERT_EQ(j.status, 0);
  const auto sj = nlohmann::json::parse(j.output);
  EXPECT_TRUE(sj["outside_envelope"].get<bool>());
  EXPECT_GT(sj["envelope"]["v"]["outside"].get<int>(), 1000);
  EXPECT_GT(sj["envelope"]["v"]["largest_excursion"].get<double>(), 10.0);
  EXPECT_EQ(sj["envelope"]["E"]["outside"].get<int>(), 0);
  EXPECT_NE(test::FileBytes(tmp.File("err.txt")).find("warning: "), std::string::npos);
  if (GnuplotAvailable()) {  // report: on stderr and in the summary
    const auto r =
        Mrd("report" + model + " --data " + File("wide.csv") + " --out " + tmp.File("rep"));
    ASSERT_EQ(r.status, 0) << r.output;
    const std::string summary = test::FileBytes(tmp.File("rep/summary.txt"));
    EXPECT_TRUE(std::regex_search(summary, warn)) << summary;
    EXPECT_NE(summary.find("residuals: N 7999"), std::string::npos) << summary;
    EXPECT_NE(summary.find("(J: unweighted MSE of normalised f)"), std::string::npos);
    EXPECT_TRUE(fs::is_regular_file(tmp.File("rep/wide_residuals.png")));
  }
}

TEST_F(JudgeCliTest, ResidListsLagsOutsideTheBand) {
  const test::TempDir tmp;
  const auto r = MrdStdout(
      "resid --json --max-lag 10 --model " + File("exact.json") + " --data " + File("in1.csv"),
      tmp.File("err.txt"));
  ASSERT_EQ(r.status, 0) << r.output << test::FileBytes(tmp.File("err.txt"));
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["samples"].get<int>(), 7999);
  EXPECT_NEAR(j["band"].get<double>(), 2.58 / std::sqrt(7999.0), 1e-12);
  const auto& c = j["correlations"];
  ASSERT_EQ(c.size(), 6u);
  EXPECT_EQ(c[0]["name"], "free-run residual: autocorrelation");
  EXPECT_EQ(c[0]["outside"].front().get<int>(), 1);  // coloured: lag 1 out
  EXPECT_TRUE(c[1]["outside"].empty()) << c[1];      // one-step: white equation noise
  EXPECT_EQ(c[2]["name"], "free-run residual: cross-correlation with E");
  EXPECT_EQ(c[4]["name"], "free-run residual: cross-correlation with v");
  EXPECT_EQ(c[2]["lags"].size(), 21u);
  // Text and plot.
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  const auto t = Mrd("resid --max-lag 10 --model " + File("exact.json") + " --data " +
                     File("in1.csv") + " --out " + tmp.File("res"));
  ASSERT_EQ(t.status, 0) << t.output;
  EXPECT_NE(t.output.find("one-step residual: autocorrelation: max |r| "), std::string::npos);
  EXPECT_NE(t.output.find("0 of 10 lags outside: none"), std::string::npos) << t.output;
  EXPECT_NE(t.output.find("99 % band +-2.58/sqrt(N) = +-"), std::string::npos) << t.output;
  EXPECT_TRUE(fs::is_regular_file(tmp.File("res/in1_residuals.png")));
  EXPECT_TRUE(fs::is_regular_file(tmp.File("res/residuals.txt")));
}

// Every refusal: exit 2, the file and the reason named, nothing written.
TEST_F(JudgeCliTest, BadInputsAreRefusedNamingFileAndReason) {
  const test::TempDir tmp;
  const auto bad = tmp.Write("bad.csv", "t,x,v,E,f\n0,0,0,0,0\n0.001,0,zero,0,0\n");
  const auto nof = tmp.Write("nof.csv", "t,x,v,E\n0,0,0,0\n0.001,0,0,0\n0.002,0,0,0\n");
  const auto badjson = tmp.Write("bad.json", "{\"format\": \"mrd-sem-model\"");
  const auto missing = tmp.File("absent.json");
  const std::string models = " --model " + File("exact.json") + ",";
  const std::string out = " --out " + tmp.File("o");
  struct Case {
    std::string args, needle;
  };
  const std::vector<Case> cases = {
      {"compare" + models + missing + " --data " + File("in1.csv") + out, missing},
      {"compare" + models + badjson + " --data " + File("in1.csv") + out, badjson},
      {"compare" + models + File("off.json") + " --data " + File("in1.csv") + "," + bad + out,
       bad + ":3: "},
      {"compare" + models + File("off.json") + " --data " + nof + out,
       nof + ":1: missing column 'f'"},
      {"compare" + models + File("off.json") + " --data " + tmp.File("none.csv") + out,
       tmp.File("none.csv")},
      {"compare" + models + File("off.json") + " --data " + File("in1.csv") + " --out " + bad,
       "exists and is not a directory"},
      {"resid --model " + missing + " --data " + File("in1.csv") + out, missing},
      {"resid --model " + File("exact.json") + " --data " + bad + out, bad + ":3: "},
      {"resid --model " + File("exact.json") + " --data " + nof + out, "missing column 'f'"},
      {"resid --max-lag 0 --model " + File("exact.json") + " --data " + File("in1.csv"),
       "--max-lag"},
      {"resid --max-lag 9000 --model " + File("exact.json") + " --data " + File("in1.csv") + out,
       "--max-lag 9000"},
  };
  for (const Case& c : cases) {
    const auto r = Mrd(c.args);
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.needle), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_FALSE(fs::exists(tmp.File("o"))) << c.args;
  }
  for (const auto& e : fs::directory_iterator(tmp.File(""))) {
    EXPECT_EQ(e.path().filename().string().find(".o."), std::string::npos) << e.path();
  }
}

TEST_F(JudgeCliTest, HelpListsOptionsAndProfiles) {
  const auto g = Mrd("generate --help");
  ASSERT_EQ(g.status, 0);
  EXPECT_NE(g.output.find("identification | v1 | v2 | v3 | wide"), std::string::npos) << g.output;
  for (const char* cmd : {"compare", "resid"}) {
    const auto h = Mrd(std::string(cmd) + " --help");
    ASSERT_EQ(h.status, 0) << h.output;
    for (const char* opt : {"--model", "--data", "--out", "--json"}) {
      EXPECT_NE(h.output.find(opt), std::string::npos) << cmd << " " << opt;
    }
  }
  EXPECT_NE(Mrd("resid --help").output.find("--max-lag"), std::string::npos);
  EXPECT_NE(Mrd("report --help").output.find("--max-lag"), std::string::npos);
}

}  // namespace
}  // namespace mrd::host
