// Residual correlations and the envelope check (host/residuals.hpp, host/model_judge.hpp), in
// the library (labels sem, unit).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "judge_fixture.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_judge.hpp"
#include "mrd/host/residuals.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

std::vector<double> WhiteNoise(std::size_t n, std::uint64_t seed) {
  test::Gauss g(seed);
  std::vector<double> e(n);
  for (double& x : e) x = g();
  return e;
}

// A ResidualAnalysis of one-step residual e and one input u, as AnalyseResiduals builds it.
ResidualAnalysis AnalysisOf(const std::vector<double>& u, const std::vector<double>& e) {
  ResidualAnalysis a;
  a.samples = e.size();
  a.max_lag = 20;
  a.band = kBand99 / std::sqrt(static_cast<double>(e.size()));
  a.inputs = {"v"};
  a.correlations = {AutoCorrelation(e, a.max_lag, a.band), AutoCorrelation(e, a.max_lag, a.band),
                    CrossCorrelation(u, e, a.max_lag, a.band),
                    CrossCorrelation(u, e, a.max_lag, a.band)};
  return a;
}

std::string Joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

// What the residuals suggest, in words: missing autoregressive terms, missing input dynamics,
// closed-loop data, or nothing.
TEST(ResidualAdviceTest, NamesWhatAFailedTestSuggests) {
  const std::size_t n = 20000;
  const std::vector<double> u = WhiteNoise(n, 3), w = WhiteNoise(n, 4);
  // White and independent of u: nothing suggested.
  const std::string white = Joined(ResidualAdvice(AnalysisOf(u, w)));
  EXPECT_NE(white.find("nothing suggests missing dynamics"), std::string::npos) << white;
  // e(k) = 0.6 e(k-1) + w(k): autoregressive terms missing.
  std::vector<double> ar(n);
  for (std::size_t k = 0; k < n; ++k) ar[k] = (k > 0 ? 0.6 * ar[k - 1] : 0.0) + w[k];
  const std::string a1 = Joined(ResidualAdvice(AnalysisOf(u, ar)));
  EXPECT_NE(a1.find("correlated with itself at lags 1"), std::string::npos) << a1;
  EXPECT_NE(a1.find("[[regressor]] of the output signal"), std::string::npos) << a1;
  // e(k) = 0.5 u(k-2) + w(k): the input leads by 2 samples, delays of v missing.
  std::vector<double> lead(n);
  for (std::size_t k = 0; k < n; ++k) lead[k] = (k >= 2 ? 0.5 * u[k - 2] : 0.0) + w[k];
  const std::string a2 = Joined(ResidualAdvice(AnalysisOf(u, lead)));
  EXPECT_NE(a2.find("still follows v at lags 2:"), std::string::npos) << a2;
  EXPECT_NE(a2.find("low_pass"), std::string::npos) << a2;
  EXPECT_EQ(a2.find("closed-loop"), std::string::npos) << a2;
  // u(k) = 0.5 e(k-3) + ...: the input follows the residual, closed-loop data.
  std::vector<double> fb(n);
  for (std::size_t k = 0; k < n; ++k) fb[k] = (k >= 3 ? 0.5 * w[k - 3] : 0.0) + u[k];
  const std::string a3 = Joined(ResidualAdvice(AnalysisOf(fb, w)));
  EXPECT_NE(a3.find("v follows the residual at lags -3"), std::string::npos) << a3;
  // The summary carries the advice.
  EXPECT_NE(ResidualSummary(AnalysisOf(u, ar), "N").find("  suggests: the one-step residual"),
            std::string::npos);
}

TEST(ResidualCorrelationTest, WhiteNoiseStaysInsideTheBand) {
  const std::size_t n = 20000;
  const double band = kBand99 / std::sqrt(static_cast<double>(n));
  const Correlation c = AutoCorrelation(WhiteNoise(n, 7), 30, band);
  ASSERT_EQ(c.lags.size(), 31u);
  EXPECT_DOUBLE_EQ(c.r[0], 1.0);
  // At 99 % about 0.3 of 30 lags of a white signal leave the band by chance (this seed: one,
  // lag 13 at 0.023); a coloured signal leaves it at most lags and far (next test).
  EXPECT_LE(c.outside.size(), 1u) << FormatLags(c.outside);
  for (std::size_t i = 1; i < c.r.size(); ++i) EXPECT_LT(std::fabs(c.r[i]), 1.5 * band) << i;
  // Independent white signals: their cross-correlation stays inside as well.
  const Correlation x = CrossCorrelation(WhiteNoise(n, 8), WhiteNoise(n, 7), 30, band);
  ASSERT_EQ(x.lags.size(), 61u);
  EXPECT_EQ(x.lags.front(), -30);
  EXPECT_LE(x.outside.size(), 2u) << FormatLags(x.outside);  // 0.6 of 61 expected
  for (const double r : x.r) EXPECT_LT(std::fabs(r), 1.5 * band);
}

TEST(ResidualCorrelationTest, ColouredNoiseLeavesTheBand) {
  // AR(1) with pole 0.8: r(tau) = 0.8^tau, outside the band for the first lags.
  const std::size_t n = 20000;
  const double band = kBand99 / std::sqrt(static_cast<double>(n));
  std::vector<double> e = WhiteNoise(n, 7);
  for (std::size_t k = 1; k < n; ++k) e[k] += 0.8 * e[k - 1];
  const Correlation c = AutoCorrelation(e, 30, band);
  EXPECT_NEAR(c.r[1], 0.8, 0.02);
  EXPECT_NEAR(c.r[2], 0.64, 0.03);
  ASSERT_FALSE(c.outside.empty());
  EXPECT_EQ(c.outside.front(), 1);
  EXPECT_GE(c.outside.size(), 10u);
  // A residual that follows an input one sample later: cross-correlation peaks at lag +1.
  const std::vector<double> u = WhiteNoise(n, 9);
  std::vector<double> r = WhiteNoise(n, 10);
  for (std::size_t k = 1; k < n; ++k) r[k] += u[k - 1];
  const Correlation x = CrossCorrelation(u, r, 5, band);
  EXPECT_NEAR(x.r[6], std::sqrt(0.5), 0.02);  // lag +1 at index 5 + 1
  EXPECT_EQ(x.outside, std::vector<int>{1});
}

TEST(ResidualCorrelationTest, LagsAndShapesAreChecked) {
  EXPECT_THROW(AutoCorrelation({1, 2, 3}, 3, 0.1), std::invalid_argument);
  EXPECT_THROW(AutoCorrelation({1, 2, 3}, -1, 0.1), std::invalid_argument);
  EXPECT_THROW(CrossCorrelation({1, 2, 3}, {1, 2}, 1, 0.1), std::invalid_argument);
  const Correlation flat = AutoCorrelation({2, 2, 2, 2}, 2, 0.1);  // zero variance
  EXPECT_EQ(flat.r, (std::vector<double>{0, 0, 0}));
  EXPECT_EQ(FormatLags({}), "none");
  EXPECT_EQ(FormatLags({1, 2, 3, 5, 7, 8}), "1...3, 5, 7...8");
}

TEST(ResidualAnalysisTest, ExactArxModelHasWhiteOneStepAndColouredFreeRunResidual) {
  test::TempDir dir;
  test::WriteArxModel(dir.File("m.json"), 0.9, 0.05, 0.08);
  test::WriteArxData(dir.File("d.csv"), 15.0, 0.01, 3, 20000);
  const ModelFile mf = LoadModelFile(dir.File("m.json"));
  const DataSet data = ReadCsv(dir.File("d.csv"));
  const ResidualAnalysis a = AnalyseResiduals(mf, 1, data, 20);
  EXPECT_EQ(a.samples, 19999u);  // one warm-up row
  EXPECT_NEAR(a.band, 2.58 / std::sqrt(19999.0), 1e-12);
  ASSERT_EQ(a.inputs, (std::vector<std::string>{"E", "v"}));
  ASSERT_EQ(a.correlations.size(), 6u);
  EXPECT_NEAR(a.rms_one_step, 10.0, 0.3);  // 0.01 normalised = 10 N
  EXPECT_GT(a.rms_free_run, 2.0 * a.rms_one_step);
  EXPECT_TRUE(a.correlations[1].outside.empty()) << FormatLags(a.correlations[1].outside);
  EXPECT_NEAR(a.correlations[0].r[1], 0.9, 0.03);  // AR(1) pole of the free-run error
  EXPECT_EQ(a.correlations[0].outside.front(), 1);
  EXPECT_GE(a.correlations[0].outside.size(), 15u);
  EXPECT_THROW(AnalyseResiduals(mf, 1, data, 0), std::invalid_argument);
  EXPECT_THROW(AnalyseResiduals(mf, 1, data, 19999), InputError);
}

TEST(EnvelopeCheckTest, CountsSamplesOutsideAndTheLargestExcursion) {
  test::TempDir dir;
  test::WriteArxModel(dir.File("m.json"), 0.9, 0.05, 0.08);
  const ModelFile mf = LoadModelFile(dir.File("m.json"));
  DataSet d = test::MakeDataSet("d.csv", {"v", "E", "f"},
                                {{0, 16, -20, 3, 15}, {0, 1, 2.25, 2.3, 0}, {0, 0, 0, 0, 0}});
  const auto checks = CheckEnvelope(mf, d);
  ASSERT_EQ(checks.size(), 2u);
  EXPECT_EQ(checks[0].channel, "E");
  EXPECT_EQ(checks[0].outside, 1u);
  EXPECT_NEAR(checks[0].largest_excursion, 0.05, 1e-12);
  EXPECT_EQ(checks[1].channel, "v");
  EXPECT_EQ(checks[1].unit, "cm/s");
  EXPECT_EQ(checks[1].outside, 2u);  // 15 is on the edge: inside
  EXPECT_DOUBLE_EQ(checks[1].outside_share(), 0.4);
  EXPECT_DOUBLE_EQ(checks[1].largest_excursion, 5.0);
  EXPECT_DOUBLE_EQ(checks[1].worst_value, -20.0);
  const auto lines = EnvelopeWarnings("m.json", "d.csv", checks);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[1],
            "warning: m.json on d.csv: v outside the identification envelope [-15, 15] cm/s in "
            "40.0 % of samples (2 of 5), largest excursion 5 cm/s beyond (v = -20 cm/s)");
  const auto j = EnvelopeJson(checks);
  EXPECT_EQ(j["v"]["outside"].get<int>(), 2);
  EXPECT_EQ(j["v"]["unit"].get<std::string>(), "cm/s");
  // Inside: no warning.
  DataSet in =
      test::MakeDataSet("in.csv", {"v", "E", "f"}, {{0, 15, -15}, {0, 2.25, 1}, {0, 0, 0}});
  EXPECT_FALSE(AnyOutside(CheckEnvelope(mf, in)));
  EXPECT_TRUE(EnvelopeWarnings("m.json", "in.csv", CheckEnvelope(mf, in)).empty());
}

TEST(ModelJudgeTest, UnitsAndWeightingNames) {
  EXPECT_EQ(SignalUnit("f"), "N");
  EXPECT_EQ(SignalUnit("v"), "cm/s");
  EXPECT_EQ(SignalUnit("q"), "");
  EXPECT_EQ(WithUnit(12.5, "f"), "12.5 N");
  test::TempDir dir;
  test::WriteArxModel(dir.File("m.json"), 0.9, 0.05, 0.08);
  test::WriteArxModel(dir.File("r.json"), 0.9, 0.05, 0.08, true);
  EXPECT_EQ(CostWeightingName(LoadModelFile(dir.File("m.json"))), "unweighted MSE of normalised f");
  EXPECT_EQ(CostWeightingShort(LoadModelFile(dir.File("r.json"))), "rel, floor 0.1");
  EXPECT_EQ(CostWeightingName(LoadModelFile(dir.File("r.json"))),
            "relative weighting 1/max(|f_n|, 0.1) of normalised f");
}

}  // namespace
}  // namespace mrd::host
