// SEM engine: agreement of the fast search path with mrd::ModelRunner, determinism across
// thread counts, rejection of diverging candidates, paper regression on damper data.
#include <gtest/gtest.h>

#include <cmath>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem.hpp"
#include "sem/engine/kernels.hpp"
#include "sem_test_util.hpp"

namespace mrd::host {
namespace {

SemSpec PaperSpec() { return LoadSemSpec(std::string(MRD_SOURCE_DIR) + "/host/specs/paper.toml"); }
// The paper's search as published: without the invertibility gate the shipped spec sets
// (monotone_in rejects candidates the paper's search accepts, so its J targets do not apply).
SemSpec PaperSearchSpec() {
  SemSpec s = PaperSpec();
  s.monotone_in.clear();
  return s;
}

// Shortened identification set (first 10 s) shared by several tests.
const DataSet& ShortDamperData() {
  static const DataSet d = test::DamperData("identification", 10001);
  return d;
}

TEST(SemEngineTest, CostAgreesWithModelRunner) {
  const SemSpec spec = PaperSpec();
  const std::vector<DataSet> id{ShortDamperData()};
  SemOptions o;
  o.max_iterations = 6;
  o.threads = 2;
  const SemResult r = Identify(spec, id, {}, o);
  ASSERT_TRUE(r.fast_path);
  ASSERT_EQ(r.iterations.size(), 7u);
  const ModelFile mf = MakeModelFile(spec, r);
  for (const auto& it : r.iterations) {
    if (it.terms.empty()) continue;
    const SimMetrics m = SimulateModel(mf, it.iteration, id[0]);
    EXPECT_NEAR(m.j, it.j, 1e-9 * it.j) << "iteration " << it.iteration;
    // The reference per-sample evaluator agrees too.
    EXPECT_NEAR(SimulateCost(spec, r.channels, it.terms, it.coefficients, id[0]), it.j,
                1e-9 * it.j);
  }
  // J decreases over the iterations (pruning never goes above the previous iteration).
  for (std::size_t i = 1; i < r.iterations.size(); ++i) {
    EXPECT_LT(r.iterations[i].j, r.iterations[i - 1].j);
  }
}

// A spec whose command enters through a low-pass filter (host/specs/nees.toml style).
TEST(SemEngineTest, LowPassCostAgreesWithModelRunner) {
  const SemSpec spec = ParseSemSpec(test::kLowPassSpec, "lp.toml");
  // 5 ... 15 s of the identification set: the record starts at a non-zero voltage, so a
  // filter started from anything but r(-1) = 0 in one of the evaluators would show.
  DataSet d = test::DamperData("identification", 15001);
  for (auto& c : d.columns) c.erase(c.begin(), c.begin() + 5000);
  ASSERT_GT(d.Column("E").front(), 0.1);
  const std::vector<DataSet> id{d};
  SemOptions o;
  o.max_iterations = 5;
  o.threads = 2;
  const SemResult r = Identify(spec, id, {}, o);
  const ModelFile mf = MakeModelFile(spec, r);
  bool uses_low_pass = false;
  for (const auto& it : r.iterations) {
    if (it.terms.empty()) continue;
    for (const auto& t : it.terms) {
      for (const auto& f : t.factors) uses_low_pass |= f.regressor == 1;
    }
    // 1e-7, not 1e-9 as for the paper spec: late iterations here carry a near-unit feedback
    // gain (e.g. 0.99 * y(k-1) * e(k-2) * |v|^0.6) that amplifies the rounding differences of
    // the evaluators' summation orders; a formula difference (filter start, delay) is >= 1e-4.
    const SimMetrics m = SimulateModel(mf, it.iteration, id[0]);
    EXPECT_NEAR(m.j, it.j, 1e-7 * it.j) << "iteration " << it.iteration;
    EXPECT_NEAR(SimulateCost(spec, r.channels, it.terms, it.coefficients, id[0]), it.j,
                1e-7 * it.j);
  }
  EXPECT_TRUE(uses_low_pass);  // the filtered command is picked, so the check means something
}

// Two runs of the same search: every iteration's terms, coefficients, J and rejected count,
// and the selection, the same bits.
void ExpectSameSearch(const SemResult& a, const SemResult& b) {
  ASSERT_EQ(a.iterations.size(), b.iterations.size());
  for (std::size_t i = 0; i < a.iterations.size(); ++i) {
    EXPECT_EQ(a.iterations[i].terms, b.iterations[i].terms) << i;
    EXPECT_EQ(a.iterations[i].coefficients, b.iterations[i].coefficients) << i;
    EXPECT_EQ(a.iterations[i].j, b.iterations[i].j) << i;
    EXPECT_EQ(a.iterations[i].rejected, b.iterations[i].rejected) << i;
  }
  EXPECT_EQ(a.selected, b.selected);
}

TEST(SemEngineTest, SameResultWithOneAndTwoThreads) {
  const SemSpec spec = PaperSpec();
  const std::vector<DataSet> id{ShortDamperData()};
  for (Strategy st : {Strategy::kBest, Strategy::kFirst}) {
    SemOptions o;
    o.max_iterations = 5;
    o.strategy = st;
    o.threads = 1;
    const SemResult a = Identify(spec, id, {}, o);
    o.threads = 2;  // the refinement (paper.toml: refine = true) runs beside the search
    std::vector<std::pair<int, double>> reported;  // progress: iteration, J
    o.progress = [&](const SemIteration& it) { reported.emplace_back(it.iteration, it.j); };
    const SemResult b = Identify(spec, id, {}, o);
    ExpectSameSearch(a, b);
    ASSERT_EQ(reported.size(), b.iterations.size());
    for (std::size_t i = 0; i < b.iterations.size(); ++i) {
      // reported in order, each once, with the refined J it is stored with
      EXPECT_EQ(reported[i].first, b.iterations[i].iteration);
      EXPECT_EQ(reported[i].second, b.iterations[i].j);
    }
  }
}

// The kernels at 8 doubles per vector (AVX-512F) and at 4 give the same search, bit for bit:
// terms, coefficients, J and the rejected counts of every iteration.
TEST(SemEngineTest, SameResultAtEveryVectorWidth) {
  if (!internal::SetLaneWidth(8)) GTEST_SKIP() << "no AVX-512F here: one vector width only";
  struct Restore {
    ~Restore() { internal::SetLaneWidth(0); }
  } restore;
  const SemSpec spec = PaperSpec();
  const std::vector<DataSet> id{ShortDamperData()};
  SemOptions o;
  o.max_iterations = 8;
  o.threads = 2;
  const SemResult wide = Identify(spec, id, {}, o);
  ASSERT_TRUE(internal::SetLaneWidth(4));
  ExpectSameSearch(wide, Identify(spec, id, {}, o));
}

TEST(SemEngineTest, InitialStructureIsKept) {
  const SemSpec spec = PaperSpec();
  const std::vector<DataSet> id{ShortDamperData()};
  SemOptions o;
  o.max_iterations = 0;
  o.initial = std::vector<std::string>{"y(k-1)", "u3(k)*u1(k)"};
  const SemResult r = Identify(spec, id, {}, o);
  ASSERT_EQ(r.iterations.size(), 1u);
  ASSERT_EQ(r.iterations[0].terms.size(), 2u);
  EXPECT_EQ(TermName(spec, r.iterations[0].terms[1]), "u1(k)*u3(k)");
  EXPECT_TRUE(std::isfinite(r.iterations[0].j));
}

TEST(SemEngineTest, DivergingModelCostsInfinity) {
  // y(k) = 2 y(k-1): the free run doubles every sample.
  std::vector<double> u(200, 0.0), y(200, 0.0);
  for (std::size_t k = 0; k < y.size(); ++k) y[k] = std::cos(0.1 * static_cast<double>(k));
  const DataSet d = test::MakeDataSet("d", {"u", "y"}, {u, y});
  const SemSpec spec = ParseSemSpec(R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
transform = "identity"
powers = [1]
delays = [1]
)",
                                    "s.toml");
  const auto ch = ComputeScales(spec, std::vector<DataSet>{d});
  EXPECT_TRUE(std::isinf(SimulateCost(spec, ch, {ParseTerm(spec, "y(k-1)")}, {2.0}, d)));
}

TEST(SemEngineTest, DivergingCandidatesAreRejected) {
  // y(k) = u(k-1) + noise, |y| up to 1 after normalisation, with a divergence limit of 0.5:
  // the candidates that fit the data leave the limit and are rejected (counted); only
  // models that stay within it are accepted, and nothing crashes.
  test::Gauss g(7);
  const std::size_t n = 2000;
  std::vector<double> u(n), y(n, 0.0);
  for (auto& v : u) v = 2.0 * g.Uniform() - 1.0;
  for (std::size_t k = 1; k < n; ++k) y[k] = u[k - 1] + 0.05 * g();
  const DataSet d = test::MakeDataSet("d", {"u", "y"}, {u, y});
  const SemSpec spec = ParseSemSpec(R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
transform = "identity"
powers = [1, 2, 3, 4, 5]
delays = [1]
[[regressor]]
name = "u"
signal = "u"
transform = "identity"
powers = [1, 2]
delays = [1]
[limits]
max_factors = 2
[cost]
weighting = "mse"
[algorithm]
divergence_limit = 0.5
)",
                                    "s.toml");
  SemOptions o;
  o.max_iterations = 4;
  const SemResult r = Identify(spec, std::vector<DataSet>{d}, {}, o);
  ASSERT_GE(r.iterations.size(), 2u);
  EXPECT_GT(r.iterations[1].rejected, 0);
  const ModelFile mf = MakeModelFile(spec, r);
  for (const auto& it : r.iterations) {
    if (it.terms.empty()) continue;
    EXPECT_TRUE(std::isfinite(it.j));
    EXPECT_FALSE(SimulateModel(mf, it.iteration, d).diverged) << it.iteration;
  }
}

TEST(SemEngineTest, UnknownColumnNamesSpecLine) {
  const SemSpec spec = PaperSpec();
  DataSet d = ShortDamperData();
  d.names[2] = "vel";  // no column v
  try {
    Identify(spec, std::vector<DataSet>{d}, {}, SemOptions{});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), spec.path);
    EXPECT_GT(e.line(), 0u);
    EXPECT_NE(std::string(e.what()).find("unknown column 'v'"), std::string::npos) << e.what();
  }
}

TEST(SemEngineTest, SelectionPicksFewestTermsWithinTolerance) {
  std::vector<SemIteration> its(4);
  const double v[] = {1.0, 0.2, 0.105, 0.1};
  for (int i = 0; i < 4; ++i) {
    its[i].iteration = i;
    its[i].terms.resize(static_cast<std::size_t>(i));
    its[i].validation_j = {v[i]};
  }
  EXPECT_EQ(SelectIteration(its, 10.0), 2);
  EXPECT_EQ(SelectIteration(its, 1.0), 3);
}

TEST(SemEngineTest, ModelFileRoundTripsAndConvertsToRuntime) {
  const SemSpec spec = PaperSpec();
  const std::vector<DataSet> id{ShortDamperData()};
  SemOptions o;
  o.max_iterations = 3;
  const SemResult r = Identify(spec, id, {}, o);
  ModelFile mf = MakeModelFile(spec, r);
  const std::string path = ::testing::TempDir() + "/sem_model_roundtrip.json";
  SaveModelFile(mf, path);
  const ModelFile back = LoadModelFile(path);
  EXPECT_EQ(ModelFileToJson(back), ModelFileToJson(mf));
  const mrd::Model m = ToRuntimeModel(back, 3);
  EXPECT_EQ(m.num_terms, r.iterations[3].terms.size());
  EXPECT_EQ(m.Validate(), Error::kOk);
}

TEST(SemEngineTest, RuntimeConversionRefusesOverCapacity) {
  ModelFile mf;
  mf.spec = PaperSpec();
  mf.channels = {{"f", 0, 1}, {"E", 0, 1}, {"v", 0, 1}};
  SemIteration it;
  it.iteration = 0;
  for (std::size_t i = 0; i < kMaxTerms + 1; ++i) {
    it.terms.push_back(ParseTerm(mf.spec, "y(k-1)"));
    it.coefficients.push_back(0.0);
  }
  mf.iterations = {it};
  try {
    ToRuntimeModel(mf, 0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("65 terms > capacity 64"), std::string::npos) << e.what();
  }
}

const DataSet& FullDamperData() {
  static const DataSet d = test::DamperData("identification");
  return d;
}

// Paper target with first improvement (one-step ranked candidates, 2 % threshold): a model
// of at most 13 terms with J <= 0.0016 (paper: 0.001596) within 28 iterations.
TEST(SemEngineTest, PaperThirteenTermTargetFirstImprovement) {
  const SemSpec spec = PaperSearchSpec();
  const std::vector<DataSet> id{FullDamperData()};
  SemOptions o;
  o.max_iterations = 28;
  o.strategy = Strategy::kFirst;
  o.threshold_percent = 2.0;
  o.threads = 2;
  const SemResult r = Identify(spec, id, {}, o);
  double best = 1e9;
  for (const auto& it : r.iterations) {
    if (it.terms.size() <= 13) best = std::min(best, it.j);
  }
  EXPECT_LE(best, 0.0016);
}

// Paper target with the default best improvement: <= 13 terms and J <= 0.0016 within the
// paper spec's 20 iterations.
TEST(SemEngineTest, PaperThirteenTermTargetBestImprovement) {
  const SemSpec spec = PaperSearchSpec();
  const std::vector<DataSet> id{FullDamperData()};
  SemOptions o;
  o.threads = 2;
  const SemResult r = Identify(spec, id, {}, o);
  ASSERT_EQ(r.iterations.size(), 21u);
  double best = 1e9;
  for (const auto& it : r.iterations) {
    if (it.terms.size() <= 13) best = std::min(best, it.j);
  }
  EXPECT_LE(best, 0.0016);
}

// Regression on the full reference identification set (seed 1), shortened run: the search
// must reach the paper's compact-model level (6 terms, J <= 0.0048) within 8 iterations.
TEST(SemEngineTest, PaperRegressionEightIterations) {
  const SemSpec spec = PaperSpec();
  const std::vector<DataSet> id{FullDamperData()};
  SemOptions o;
  o.max_iterations = 8;
  o.threads = 2;
  const SemResult r = Identify(spec, id, {}, o);
  EXPECT_EQ(r.num_candidates, 1551u);
  double best_small = 1e9;
  for (const auto& it : r.iterations) {
    if (it.terms.size() <= 6) best_small = std::min(best_small, it.j);
  }
  EXPECT_LE(best_small, 0.0048);
  const ModelFile mf = MakeModelFile(spec, r);
  const SimMetrics m = SimulateModel(mf, 8, id[0]);
  EXPECT_NEAR(m.j, r.iterations[8].j, 1e-9 * m.j);
}

}  // namespace
}  // namespace mrd::host
