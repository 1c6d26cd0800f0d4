// End-to-end tests of `mrd report` through the executable, on a small damper model
// identified once per suite.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "mrd/host/csv.hpp"
#include "mrd/host/plot.hpp"
#include "sem_test_util.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

namespace fs = std::filesystem;

// A few candidates from f(k-1), E(k), |v(k)|^0.2 and sign(v(k)): identifies in well under a
// second on a few thousand samples.
constexpr const char* kSmallSpec = R"(output = "f"
[[regressor]]
name = "y"
signal = "f"
transform = "identity"
powers = [1, 2]
delays = [1]
[[regressor]]
name = "u1"
signal = "E"
transform = "identity"
powers = [1, 2]
delays = [0]
[[regressor]]
name = "u2"
signal = "v"
transform = "abs_pow"
exponent = 0.2
powers = [1, 2, 3, 4]
delays = [0]
[[regressor]]
name = "u3"
signal = "v"
transform = "sign"
powers = [1]
delays = [0]
[limits]
max_factors = 3
[algorithm]
max_iterations = 4
one_step_start = false  # the greedy path: iteration 1 has 1 term
)";

std::string Read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteDataSet(const DataSet& d, const std::string& path,
                  const std::vector<std::string>& drop = {}) {
  std::vector<std::string> names;
  std::vector<std::vector<double>> cols;
  for (std::size_t i = 0; i < d.names.size(); ++i) {
    if (std::find(drop.begin(), drop.end(), d.names[i]) != drop.end()) continue;
    names.push_back(d.names[i]);
    cols.push_back(d.columns[i]);
  }
  WriteCsv(path, names, cols);
}

std::string RegexEscape(const std::string& s) {
  static const std::regex special(R"([.^$|()\[\]{}*+?\\/-])");
  return std::regex_replace(s, special, R"(\$&)");
}

// Figures of one data file in a summary: J, normalised MSE, RRSE, fit %.
struct Figures {
  double j = 0, mse = 0, rrse = 0, fit = 0;
};
Figures ParseFigures(const std::string& summary, const std::string& data_path) {
  const std::regex re(RegexEscape(data_path) +
                      R"(: \d+ samples scored\n    J (\S+)  MSE (\S+) \(normalised\).*\n)"
                      R"(    RRSE (\S+)  fit (\S+) %)");
  std::smatch m;
  if (!std::regex_search(summary, m, re)) {
    ADD_FAILURE() << "no figures for " << data_path << " in\n" << summary;
    return {};
  }
  return {std::stod(m[1]), std::stod(m[2]), std::stod(m[3]), std::stod(m[4])};
}

// True when the file starts with the PNG signature and is more than a few kB.
::testing::AssertionResult IsPng(const std::string& path) {
  const std::string bytes = Read(path);
  if (bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0) {
    return ::testing::AssertionFailure() << path << ": not a PNG";
  }
  if (bytes.size() < 4000) {
    return ::testing::AssertionFailure() << path << ": only " << bytes.size() << " bytes";
  }
  return ::testing::AssertionSuccess();
}

// Leftover staging directories (".NAME.report-XXXXXX") in a directory.
int StagingLeftovers(const std::string& dir) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().filename().string().find(".report-") != std::string::npos) ++n;
  }
  return n;
}

class ReportCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<test::TempDir>();
    WriteDataSet(test::DamperData("identification", 6000), dir_->File("id.csv"));
    const DataSet v1 = test::DamperData("v1", 3000);
    WriteDataSet(v1, dir_->File("v1.csv"));
    WriteDataSet(v1, dir_->File("nox.csv"), {"x"});
    WriteDataSet(v1, dir_->File("noe.csv"), {"E"});
    // A periodic run (2 Hz sine, 1.5 cm, at 1 V): its force-displacement loop reads.
    host::Excitation sine;
    for (int k = 0; k < 3000; ++k) {
      const double t = 1e-3 * k, w = 2.0 * 3.14159265358979 * 2.0;
      sine.t.push_back(t);
      sine.x.push_back(1.5 * std::sin(w * t));
      sine.v.push_back(1.5 * w * std::cos(w * t));
      sine.E.push_back(1.0);
    }
    const std::vector<double> f = SimulateReferenceDamper(host::SpencerPreset("paper"), sine, 100);
    WriteDataSet(test::MakeDataSet("sine", {"x", "v", "E", "f"}, {sine.x, sine.v, sine.E, f}),
                 dir_->File("sine.csv"));
    const auto spec = dir_->Write("small.toml", kSmallSpec);
    const auto r = test::Run(test::Bin("mrd") + " identify --data " + dir_->File("id.csv") +
                             " --validate " + dir_->File("v1.csv") + " --spec " + spec +
                             " --threads 2 --out " + dir_->File("model.json"));
    ASSERT_EQ(r.status, 0) << r.output;
  }
  static void TearDownTestSuite() { dir_.reset(); }

  static std::string File(const std::string& name) { return dir_->File(name); }
  // `mrd report` with the arguments; stdout and stderr captured together.
  static test::CommandResult Report(const std::string& args) {
    return test::Run(test::Bin("mrd") + " report " + args);
  }

  static std::unique_ptr<test::TempDir> dir_;
};
std::unique_ptr<test::TempDir> ReportCliTest::dir_;

TEST_F(ReportCliTest, WritesEveryPlotAsPng) {
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  const test::TempDir out;
  const auto dir = out.File("report");
  const auto r =
      Report("--model " + File("model.json") + " --data " + File("v1.csv") + "," + File("nox.csv") +
             " --data " + File("id.csv") + "," + File("sine.csv") + " --out " + dir);
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* name :
       {"v1_force_velocity.png", "v1_time.png", "nox_force_velocity.png", "nox_time.png",
        "id_force_velocity.png", "id_time.png", "sine_force_displacement.png",
        "sine_force_velocity.png", "sine_time.png", "J_iterations.png"}) {
    EXPECT_TRUE(IsPng(dir + "/" + name)) << name;
    EXPECT_NE(r.output.find(dir + "/" + name), std::string::npos) << name;  // listed
  }
  EXPECT_FALSE(fs::exists(dir + "/nox_force_displacement.png"));
  // Random motion: no force-displacement cloud, and the summary says why.
  for (const char* name : {"v1", "id"}) {
    EXPECT_FALSE(fs::exists(dir + "/" + name + "_force_displacement.png")) << name;
    EXPECT_NE(r.output.find(std::string(name) + ".csv: displacement not periodic: no "
                                                "force-displacement loop"),
              std::string::npos)
        << r.output;
  }
  EXPECT_NE(r.output.find("nox.csv: no column 'x': force-displacement loop skipped"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("report: simulating iteration 3/4 on id.csv"), std::string::npos)
      << r.output;
  // The model file's validation set is named by its file in the summary.
  EXPECT_NE(r.output.find("validated on: " + File("v1.csv")), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("validation v1.csv"), std::string::npos) << r.output;
  EXPECT_EQ(StagingLeftovers(out.File("")), 0);
}

// --window FROM:TO picks the time plot's window; a malformed one is bad input (exit 2, nothing
// written), one outside the record a note (the first 5 s drawn).
TEST_F(ReportCliTest, WindowFlagPicksTheTimePlotsWindow) {
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  const test::TempDir out;
  auto r = Report("--model " + File("model.json") + " --data " + File("v1.csv") + " --out " +
                  out.File("w") + " --window 1:2.5");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(IsPng(out.File("w") + "/v1_time.png"));
  r = Report("--model " + File("model.json") + " --data " + File("v1.csv") + " --out " +
             out.File("late") + " --window 100:200");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("window 100:200 s is outside the record"), std::string::npos) << r.output;
  for (const char* bad : {"2:1", "x:3", "5"}) {
    r = Report("--model " + File("model.json") + " --data " + File("v1.csv") + " --out " +
               out.File("bad") + " --window " + bad);
    EXPECT_EQ(r.status, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find("--window '"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out.File("bad"))) << bad;
  }
}

TEST_F(ReportCliTest, SummaryFiguresAgreeWithSimulate) {
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  const test::TempDir out;
  const auto dir = out.File("report");
  const auto r = test::Run("( " + test::Bin("mrd") + " report --model " + File("model.json") +
                           " --data " + File("v1.csv") + "," + File("id.csv") + " --out " + dir +
                           " 2>" + out.File("stderr.txt") + " )");
  ASSERT_EQ(r.status, 0) << r.output << Read(out.File("stderr.txt"));
  const std::string summary = Read(dir + "/summary.txt");
  EXPECT_EQ(summary, r.output);  // stdout is the summary
  EXPECT_NE(summary.find("selected iteration: "), std::string::npos) << summary;
  EXPECT_NE(summary.find("terms of iteration "), std::string::npos) << summary;
  for (const std::string& data : {File("v1.csv"), File("id.csv")}) {
    const auto s = test::Run(test::Bin("mrd") + " simulate --json --model " + File("model.json") +
                             " --data " + data);
    ASSERT_EQ(s.status, 0) << s.output;
    // stderr (merged) may start with a range warning line: the JSON object follows.
    const auto j = nlohmann::json::parse(s.output.substr(s.output.find('{')));
    const Figures f = ParseFigures(summary, data);
    const auto near6 = [](double printed, double exact) {
      return std::fabs(printed - exact) <= 1e-5 * std::fabs(exact);  // 6 significant digits
    };
    EXPECT_TRUE(near6(f.j, j["J"].get<double>())) << f.j << " vs " << j["J"];
    EXPECT_TRUE(near6(f.mse, j["mse"].get<double>())) << f.mse << " vs " << j["mse"];
    EXPECT_TRUE(near6(f.rrse, j["rrse"].get<double>())) << f.rrse << " vs " << j["rrse"];
    EXPECT_NEAR(f.fit, j["fit_percent"].get<double>(), 5.0001e-4);
  }
}

TEST_F(ReportCliTest, IterationFlagReportsThatIteration) {
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  const test::TempDir out;
  const auto dir = out.File("report");
  const auto r = Report("--model " + File("model.json") + " --data " + File("v1.csv") +
                        " --iteration 1 --out " + dir);
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string summary = Read(dir + "/summary.txt");
  EXPECT_NE(summary.find("reported iteration: 1 (1 terms"), std::string::npos) << summary;
  const auto s = test::Run(test::Bin("mrd") + " simulate --json --iteration 1 --model " +
                           File("model.json") + " --data " + File("v1.csv"));
  ASSERT_EQ(s.status, 0) << s.output;
  EXPECT_NEAR(
      ParseFigures(summary, File("v1.csv")).fit,
      nlohmann::json::parse(s.output.substr(s.output.find('{')))["fit_percent"].get<double>(),
      5.0001e-4);
}

TEST_F(ReportCliTest, DivergingIterationIsAGapNotACrash) {
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  const test::TempDir out;
  auto model = nlohmann::json::parse(Read(File("model.json")));
  // Iteration 2 becomes f(k) = 2 f(k-1) + 0.01 sign(v(k)): its free run grows without bound.
  model["iterations"][2]["terms"] = nlohmann::json::array(
      {{{"coefficient", 2.0}, {"factors", {{{"regressor", "y"}, {"delay", 1}, {"power", 1}}}}},
       {{"coefficient", 0.01}, {"factors", {{{"regressor", "u3"}, {"delay", 0}, {"power", 1}}}}}});
  const auto path = out.Write("diverging.json", model.dump());
  const auto dir = out.File("report");
  const auto r =
      Report("--model " + path + " --data " + File("v1.csv") + " --iteration 3 --out " + dir);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("v1.csv: iteration 2 diverges"), std::string::npos) << r.output;
  EXPECT_TRUE(IsPng(dir + "/J_iterations.png"));
}

TEST_F(ReportCliTest, ExistingDirectoryKeepsOtherFiles) {
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  const test::TempDir out;
  const auto dir = out.File("report");
  fs::create_directory(dir);
  out.Write("report/keep.txt", "mine");
  out.Write("report/summary.txt", "stale");
  const auto r =
      Report("--model " + File("model.json") + " --data " + File("v1.csv") + " --out " + dir);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(Read(dir + "/keep.txt"), "mine");
  EXPECT_NE(Read(dir + "/summary.txt").find("mrd report"), std::string::npos);
  EXPECT_TRUE(IsPng(dir + "/v1_time.png"));
  EXPECT_EQ(StagingLeftovers(out.File("")), 0);
}

// Bad input: exit 2, the message, no output directory and no staging leftovers.
void ExpectBadInput(const test::CommandResult& r, const test::TempDir& out,
                    const std::string& message) {
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("error: " + message), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out.File("report")));
  EXPECT_EQ(StagingLeftovers(out.File("")), 0);
}

TEST_F(ReportCliTest, MissingModelExits2) {
  const test::TempDir out;
  const auto r = Report("--model " + out.File("none.json") + " --data " + File("v1.csv") +
                        " --out " + out.File("report"));
  ExpectBadInput(r, out, out.File("none.json"));
}

TEST_F(ReportCliTest, CorruptModelJsonExits2) {
  const test::TempDir out;
  const std::string text = Read(File("model.json"));
  const auto model = out.Write("corrupt.json", text.substr(0, text.size() / 2));
  const auto r =
      Report("--model " + model + " --data " + File("v1.csv") + " --out " + out.File("report"));
  ExpectBadInput(r, out, model + ":");
}

TEST_F(ReportCliTest, DataLackingModelSignalExits2) {
  const test::TempDir out;
  const auto r = Report("--model " + File("model.json") + " --data " + File("v1.csv") + "," +
                        File("noe.csv") + " --out " + out.File("report"));
  ExpectBadInput(r, out, File("noe.csv") + ":1:");
  EXPECT_NE(r.output.find("'E'"), std::string::npos) << r.output;
}

TEST_F(ReportCliTest, MalformedDataExits2) {
  const test::TempDir out;
  const auto data = out.Write("bad.csv", "t,x,v,E,f\n0,0,0,0,0\n0.001,0,x,0,0\n");
  const auto r =
      Report("--model " + File("model.json") + " --data " + data + " --out " + out.File("report"));
  ExpectBadInput(r, out, data + ":3:");
}

TEST_F(ReportCliTest, IterationOutOfRangeExits2) {
  const test::TempDir out;
  const auto r = Report("--model " + File("model.json") + " --data " + File("v1.csv") +
                        " --iteration 99 --out " + out.File("report"));
  ExpectBadInput(r, out, File("model.json") + ": no iteration 99");
}

TEST_F(ReportCliTest, OutIsAFileExits2) {
  const test::TempDir out;
  const auto file = out.Write("report.txt", "x");
  const auto r =
      Report("--model " + File("model.json") + " --data " + File("v1.csv") + " --out " + file);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("not a directory"), std::string::npos) << r.output;
  EXPECT_EQ(Read(file), "x");
}

TEST_F(ReportCliTest, MissingGnuplotFailsWritingNothing) {
  const test::TempDir out;
  const auto r =
      test::Run("PATH=" + out.File("empty") + " " + test::Bin("mrd") + " report --model " +
                File("model.json") + " --data " + File("v1.csv") + " --out " + out.File("report"));
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("gnuplot"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out.File("report")));
  EXPECT_EQ(StagingLeftovers(out.File("")), 0);
}

TEST_F(ReportCliTest, HelpNamesTheOptions) {
  const auto r = test::Run(test::Bin("mrd") + " report --help");
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* opt : {"--model", "--data", "--out", "--iteration", "gnuplot"}) {
    EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
  }
}

}  // namespace
}  // namespace mrd::host
