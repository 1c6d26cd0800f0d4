// End-to-end tests of `mrd identify` and `mrd simulate` through the executable.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "mrd/host/csv.hpp"
#include "mrd/host/model_file.hpp"
#include "sem_test_util.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

// Small t,u,y data set from y(k) = 0.5 y(k-1) + u(k-1) + 0.3 u(k-1)^2.
std::string WriteToyData(const test::TempDir& dir, const std::string& name, std::uint64_t seed) {
  test::Gauss g(seed);
  const std::size_t n = 600;
  std::vector<double> t(n), u(n), y(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    t[k] = 0.01 * static_cast<double>(k);
    u[k] = 2.0 * g.Uniform() - 1.0;
    if (k > 0) y[k] = 0.5 * y[k - 1] + u[k - 1] + 0.3 * u[k - 1] * u[k - 1];
  }
  WriteCsv(dir.File(name), {"t", "u", "y"}, {t, u, y});
  return dir.File(name);
}

constexpr const char* kToySpec = R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
transform = "identity"
powers = [1, 2]
delays = [1]
[[regressor]]
name = "u"
signal = "u"
transform = "identity"
powers = [1, 2]
delays = [1, 2]
[limits]
max_factors = 2
max_degree = 2
[cost]
weighting = "mse"
[algorithm]
max_iterations = 4
one_step_start = false  # the greedy path: early iterations are imperfect fits
)";

TEST(SemCliTest, IdentifyThenSimulateJson) {
  test::TempDir dir;
  const auto id = WriteToyData(dir, "id.csv", 1);
  const auto val = WriteToyData(dir, "val.csv", 2);
  const auto spec = dir.Write("toy.toml", kToySpec);
  const auto model = dir.File("m.json");
  const auto r = test::Run(test::Bin("mrd") + " identify --data " + id + " --spec " + spec +
                           " --validate " + val + " --out " + model + " --threads 2");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("iteration   3:  3 terms"), std::string::npos) << r.output;
  const ModelFile mf = LoadModelFile(model);
  EXPECT_EQ(mf.identification_data, std::vector<std::string>{id});  // provenance
  EXPECT_EQ(mf.validation_data, std::vector<std::string>{val});
  EXPECT_EQ(mf.Iteration(3).terms.size(), 3u);
  EXPECT_LT(mf.Iteration(3).j, 1e-20);
  const auto s = test::Run(test::Bin("mrd") + " simulate --model " + model + " --data " + val +
                           " --iteration 3 --json --out " + dir.File("sim.csv"));
  ASSERT_EQ(s.status, 0) << s.output;
  // stderr (merged) may start with a range warning line: the JSON object follows.
  const auto j = nlohmann::json::parse(s.output.substr(s.output.find('{')));
  for (const char* key : {"J", "mse", "rrse", "fit_percent"}) EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_NEAR(j["fit_percent"].get<double>(), 100.0, 1e-6);
  EXPECT_NEAR(j["J"].get<double>(), mf.Iteration(3).validation_j[0], 1e-12);
  const DataSet sim = ReadCsv(dir.File("sim.csv"), std::vector<std::string>{"y", "y_sim"});
  EXPECT_EQ(sim.rows(), 600u);
}

TEST(SemCliTest, SimulatePrintsMetrics) {
  test::TempDir dir;
  const auto id = WriteToyData(dir, "id.csv", 1);
  const auto spec = dir.Write("toy.toml", kToySpec);
  const auto model = dir.File("m.json");
  ASSERT_EQ(test::Run(test::Bin("mrd") + " identify --data " + id + " --spec " + spec + " --out " +
                      model + " --max-iterations 1")
                .status,
            0);
  const auto s = test::Run(test::Bin("mrd") + " simulate --model " + model + " --data " + id +
                           " --out " + dir.File("sim.csv"));
  ASSERT_EQ(s.status, 0) << s.output;
  // The printed numbers are those of the written simulation (rows from the warm-up of 2 on).
  const DataSet sim = ReadCsv(dir.File("sim.csv"), std::vector<std::string>{"y", "y_sim"});
  double sse = 0.0, scale = 0.0;
  for (std::size_t k = 0; k < sim.rows(); ++k) {
    const double e = sim.Column("y")[k] - sim.Column("y_sim")[k];
    sse += e * e;
    scale = std::max(scale, std::fabs(sim.Column("y")[k]));
  }
  const double mse = sse / static_cast<double>(sim.rows() - 2);
  ASSERT_GT(mse, 1e-6);  // one iteration: an imperfect model
  const auto number_after = [&](const std::string& label) {
    const std::size_t at = s.output.find(label);
    EXPECT_NE(at, std::string::npos) << label << " in " << s.output;
    return at == std::string::npos ? std::nan("") : std::stod(s.output.substr(at + label.size()));
  };
  EXPECT_NEAR(number_after("physical:   MSE "), mse, 1e-5 * mse) << s.output;
  EXPECT_NEAR(number_after("RMSE "), std::sqrt(mse), 1e-5 * std::sqrt(mse)) << s.output;
  const double j = mse / (scale * scale);  // normalised by max |y|, MSE weighting
  EXPECT_NEAR(number_after("normalised: J "), j, 1e-5 * j) << s.output;
  EXPECT_NE(s.output.find(std::to_string(sim.rows() - 2) + " samples"), std::string::npos);
  for (const char* word : {"RRSE", "fit"}) {
    EXPECT_NE(s.output.find(word), std::string::npos) << s.output;
  }
}

TEST(SemCliTest, UnknownColumnExits2NamingSpecLine) {
  test::TempDir dir;
  const auto id = WriteToyData(dir, "id.csv", 1);
  std::string text = kToySpec;
  text.replace(text.find("signal = \"u\""), 12, "signal = \"w\"");
  const auto spec = dir.Write("toy.toml", text);
  const auto r = test::Run(test::Bin("mrd") + " identify --data " + id + " --spec " + spec +
                           " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(spec + ":10: unknown column 'w'"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("m.json")));
}

TEST(SemCliTest, BadPowerExits2) {
  test::TempDir dir;
  const auto id = WriteToyData(dir, "id.csv", 1);
  std::string text = kToySpec;
  text.replace(text.find("powers = [1, 2]\ndelays = [1, 2]"), 15, "powers = [1, -2]");
  const auto spec = dir.Write("toy.toml", text);
  const auto r = test::Run(test::Bin("mrd") + " identify --data " + id + " --spec " + spec +
                           " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(spec + ":12: bad power -2"), std::string::npos) << r.output;
}

TEST(SemCliTest, EmptyCandidateSetExits2) {
  test::TempDir dir;
  const auto id = WriteToyData(dir, "id.csv", 1);
  const auto spec = dir.Write("e.toml",
                              "output = \"y\"\n[[regressor]]\nname = \"s\"\nsignal = \"u\"\n"
                              "transform = \"sign\"\npowers = [2]\n");
  const auto r = test::Run(test::Bin("mrd") + " identify --data " + id + " --spec " + spec +
                           " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("empty candidate set"), std::string::npos) << r.output;
}

TEST(SemCliTest, MalformedSpecExits2) {
  test::TempDir dir;
  const auto id = WriteToyData(dir, "id.csv", 1);
  const auto spec = dir.Write("m.toml", "output = \"y\"\n[[regressor]\n");
  const auto r = test::Run(test::Bin("mrd") + " identify --data " + id + " --spec " + spec +
                           " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(spec + ":2:"), std::string::npos) << r.output;
}

TEST(SemCliTest, BadDataExits2) {
  test::TempDir dir;
  const auto spec = dir.Write("toy.toml", kToySpec);
  const auto data = dir.Write("bad.csv", "t,u,y\n0,1,2\n0.01,x,3\n0.02,1,1\n");
  const auto r = test::Run(test::Bin("mrd") + " identify --data " + data + " --spec " + spec +
                           " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(data + ":3:"), std::string::npos) << r.output;
}

TEST(SemCliTest, BadModelFileExits2) {
  test::TempDir dir;
  const auto id = WriteToyData(dir, "id.csv", 1);
  const auto model = dir.Write("m.json", "{\"format\": \"mrd-sem-model\"}");
  const auto r = test::Run(test::Bin("mrd") + " simulate --model " + model + " --data " + id);
  EXPECT_EQ(r.status, 2) << r.output;
}

}  // namespace
}  // namespace mrd::host
