// Numbers the host CLI prints and writes, checked against values recomputed from its own
// outputs: `mrd simulate` metrics against the simulation CSV, `mrd export` ranges and
// coefficients against the decoded table; the CSV reader's sampling check on a shrinking step.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <regex>

#include "mrd/common/table.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "sem_test_util.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

// t, u, y from y(k) = 0.5 y(k-1) + u(k-1) + 0.3 u(k-1)^2 with u in [-1, 1]: |y| reaches
// several units, so the output scale is far from 1.
std::string WriteToyData(const test::TempDir& dir) {
  test::Gauss g(3);
  const std::size_t n = 500;
  std::vector<double> t(n), u(n), y(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    t[k] = 0.01 * static_cast<double>(k);
    u[k] = 2.0 * g.Uniform() - 1.0;
    // u(k) enters directly, so a model of it can be exported (inverted in u).
    y[k] = (k > 0 ? 0.5 * y[k - 1] : 0.0) + u[k] + 0.3 * u[k] * u[k];
  }
  WriteCsv(dir.File("toy.csv"), {"t", "u", "y"}, {t, u, y});
  return dir.File("toy.csv");
}

constexpr const char* kToySpec = R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
transform = "identity"
powers = [1]
delays = [1, 2]
[[regressor]]
name = "u"
signal = "u"
transform = "identity"
powers = [1, 2]
delays = [0]
[limits]
max_factors = 1
[cost]
weighting = "mse"
[algorithm]
one_step_start = false  # the greedy path: early iterations are imperfect fits
)";

// A two-iteration model of the toy data (an imperfect fit: non-zero errors).
std::string IdentifyToy(const test::TempDir& dir, const std::string& data) {
  const auto spec = dir.Write("toy.toml", kToySpec);
  const auto model = dir.File("m.json");
  const auto r = test::Run(test::Bin("mrd") + " identify --data " + data + " --spec " + spec +
                           " --out " + model + " --max-iterations 2");
  EXPECT_EQ(r.status, 0) << r.output;
  return model;
}

struct Recomputed {
  double scale = 0.0;  // max |y|
  double mse_physical = 0.0, rrse = 0.0;
  std::size_t samples = 0;
};

// Metrics from the written simulation (rows before the warm-up carry y_sim = y).
Recomputed FromSimulationCsv(const std::string& path, std::size_t warmup) {
  const DataSet sim = ReadCsv(path, std::vector<std::string>{"y", "y_sim"});
  const auto& y = sim.Column("y");
  const auto& ys = sim.Column("y_sim");
  Recomputed r;
  double sse = 0.0, sy = 0.0, syy = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) {
    r.scale = std::max(r.scale, std::fabs(y[k]));
    if (k < warmup) {
      EXPECT_EQ(ys[k], y[k]);
      continue;
    }
    sse += (y[k] - ys[k]) * (y[k] - ys[k]);
    sy += y[k];
    syy += y[k] * y[k];
    ++r.samples;
  }
  const double n = static_cast<double>(r.samples);
  r.mse_physical = sse / n;
  r.rrse = std::sqrt(sse / (syy - sy * sy / n));
  return r;
}

TEST(CliValuesTest, SimulateJsonMetricsMatchTheWrittenSimulation) {
  test::TempDir dir;
  const auto data = WriteToyData(dir);
  const auto model = IdentifyToy(dir, data);
  const auto s = test::Run(test::Bin("mrd") + " simulate --model " + model + " --data " + data +
                           " --json --out " + dir.File("sim.csv"));
  ASSERT_EQ(s.status, 0) << s.output;
  const auto j = nlohmann::json::parse(s.output);
  const Recomputed r = FromSimulationCsv(dir.File("sim.csv"), 2);
  ASSERT_GT(r.scale, 2.0);  // a missing scale factor would show
  EXPECT_EQ(j["samples"].get<std::size_t>(), r.samples);
  ASSERT_GT(r.mse_physical, 1e-6);
  EXPECT_NEAR(j["mse_physical"].get<double>(), r.mse_physical, 1e-6 * r.mse_physical);
  EXPECT_NEAR(j["rmse_physical"].get<double>(), std::sqrt(r.mse_physical),
              1e-6 * std::sqrt(r.mse_physical));
  // Normalised MSE: the output divided by its scale max |y|.
  EXPECT_NEAR(j["mse"].get<double>(), r.mse_physical / (r.scale * r.scale),
              1e-6 * j["mse"].get<double>());
  EXPECT_NEAR(j["J"].get<double>(), j["mse"].get<double>(), 1e-12);  // mse weighting
  EXPECT_NEAR(j["rrse"].get<double>(), r.rrse, 1e-6 * r.rrse);
  EXPECT_NEAR(j["fit_percent"].get<double>(), 100.0 * (1.0 - r.rrse), 1e-4);
}

// Value after a label in the text output, e.g. "RMSE 0.123".
double After(const std::string& text, const std::string& label) {
  std::smatch m;
  const std::regex re(label + R"(\s+([-+0-9.eE]+))");
  EXPECT_TRUE(std::regex_search(text, m, re)) << label << " in " << text;
  return m.empty() ? std::nan("") : std::stod(m[1].str());
}

TEST(CliValuesTest, SimulateTextMetricsMatchTheWrittenSimulation) {
  test::TempDir dir;
  const auto data = WriteToyData(dir);
  const auto model = IdentifyToy(dir, data);
  const auto s = test::Run(test::Bin("mrd") + " simulate --model " + model + " --data " + data +
                           " --out " + dir.File("sim.csv"));
  ASSERT_EQ(s.status, 0) << s.output;
  const Recomputed r = FromSimulationCsv(dir.File("sim.csv"), 2);
  // Printed with 6 significant digits.
  EXPECT_NEAR(After(s.output, "physical:   MSE"), r.mse_physical, 1e-5 * r.mse_physical);
  EXPECT_NEAR(After(s.output, "RMSE"), std::sqrt(r.mse_physical), 1e-5 * std::sqrt(r.mse_physical));
  EXPECT_NEAR(After(s.output, "RRSE"), r.rrse, 1e-5 * r.rrse);
  EXPECT_NEAR(After(s.output, "fit"), 100.0 * (1.0 - r.rrse), 2e-3);
  EXPECT_NE(s.output.find(std::to_string(r.samples) + " samples"), std::string::npos) << s.output;
}

std::vector<std::uint8_t> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Without --e-min/--e-max the command range is the one the identification data reached,
// clamped to [0, ...] V (the toy's u spans about +-1 V: a warning names both ranges).
TEST(CliValuesTest, ExportDefaultsToTheDataRangeAndRoundTripsCoefficients) {
  test::TempDir dir;
  const auto model = IdentifyToy(dir, WriteToyData(dir));
  const auto bin = dir.File("t.bin");
  const auto r =
      test::Run(test::Bin("mrd") + " export --model " + model + " --input u --table " + bin);
  ASSERT_EQ(r.status, 0) << r.output;
  const ModelFile mf = LoadModelFile(model);
  double u_max = 0.0;
  for (const auto& c : mf.channels) {
    if (c.name == "u") u_max = c.max;
  }
  ASSERT_GT(u_max, 0.9);
  EXPECT_NE(r.output.find(fmt::format("in [0, {:.4g}] V", u_max)), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("warning: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("beyond the table's range"), std::string::npos) << r.output;
  const auto t = DecodeTable(ReadBytes(bin));
  ASSERT_TRUE(t.ok()) << ErrorName(t.error());
  EXPECT_EQ(t.value().e_min, 0.0);
  EXPECT_EQ(t.value().e_max, u_max);
  const Model expected = ToRuntimeModel(mf, mf.selected);
  const Model& got = t.value().model;
  ASSERT_EQ(got.num_terms, expected.num_terms);
  ASSERT_GT(got.num_terms, 0);
  for (std::size_t i = 0; i < expected.num_terms; ++i) {
    EXPECT_EQ(got.coefficients[i], expected.coefficients[i]) << i;
  }
  for (std::size_t c = 0; c < expected.num_channels; ++c) {
    EXPECT_STREQ(got.channel_names[c].data(), expected.channel_names[c].data());
    EXPECT_EQ(got.scales[c].scale, expected.scales[c].scale) << c;
  }
  EXPECT_STREQ(got.channel_names[t.value().input_channel].data(), "u");
}

TEST(CliValuesTest, ExportWritesTheGivenVoltageRange) {
  test::TempDir dir;
  const auto model = IdentifyToy(dir, WriteToyData(dir));
  const auto bin = dir.File("t.bin");
  const auto r = test::Run(test::Bin("mrd") + " export --model " + model +
                           " --input u --e-min 0.25 --e-max 1.5 --table " + bin);
  ASSERT_EQ(r.status, 0) << r.output;
  const auto t = DecodeTable(ReadBytes(bin));
  ASSERT_TRUE(t.ok()) << ErrorName(t.error());
  EXPECT_EQ(t.value().e_min, 0.25);
  EXPECT_EQ(t.value().e_max, 1.5);
}

TEST(CliValuesTest, CsvTimeStepThatShrinksIsNonUniform) {
  test::TempDir dir;
  // Rows and the file line of the shrunken step.
  for (const auto& [rows, line] :
       {std::pair<const char*, std::size_t>{"0,1\n0.001,1\n0.002,1\n0.0025,1\n", 5},
        {"0,1\n0.001,1\n0.0015,1\n", 4}}) {
    const auto p = dir.Write("s.csv", std::string("t,y\n") + rows);
    try {
      ReadCsv(p, std::vector<std::string>{"y"});
      ADD_FAILURE() << "no error for " << rows;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("non-uniform"), std::string::npos) << e.what();
      EXPECT_EQ(e.line(), line) << e.what();
    }
  }
  // A step within the 1e-3 relative tolerance either way is accepted.
  const auto ok = dir.Write("ok.csv", "t,y\n0,1\n0.001,1\n0.0019995,1\n0.0030000,1\n");
  EXPECT_EQ(ReadCsv(ok, std::vector<std::string>{"y"}).rows(), 4U);
}

}  // namespace
}  // namespace mrd::host
