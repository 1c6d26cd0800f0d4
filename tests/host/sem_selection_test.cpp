// Issue 15: model selection without validation data (cross-validated simulation error with a
// BIC on the effective sample size), the spec header's documented example, and ParseTerm's
// refusal of powers and delays the spec does not offer.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem.hpp"
#include "sem_recovery.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

// Every ```toml block of docs/spec.md, in order.
std::vector<std::string> DocumentedBlocks() {
  std::ifstream in(std::string(MRD_SOURCE_DIR) + "/docs/spec.md");
  std::vector<std::string> blocks;
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (!inside && line == "```toml") {
      inside = true;
      blocks.emplace_back();
    } else if (inside && line == "```") {
      inside = false;
    } else if (inside) {
      blocks.back() += line + "\n";
    }
  }
  return blocks;
}

// The complete example: the first block.
std::string DocumentedExample() {
  const std::vector<std::string> blocks = DocumentedBlocks();
  return blocks.empty() ? std::string() : blocks.front();
}

TEST(SemSpecDocTest, EveryExampleOfTheSpecPageParses) {
  const std::vector<std::string> blocks = DocumentedBlocks();
  ASSERT_FALSE(blocks.empty()) << "no toml block in docs/spec.md";
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    EXPECT_NO_THROW(ParseSemSpec(blocks[i], "docs/spec.md block " + std::to_string(i + 1)))
        << blocks[i];
  }
}

TEST(SemSpecDocTest, DocumentedExampleParsesAsWritten) {
  const std::string text = DocumentedExample();
  ASSERT_NE(text.find("[algorithm]"), std::string::npos) << "example block not found";
  const SemSpec s = ParseSemSpec(text, "docs/spec.md");
  ASSERT_EQ(s.regressors.size(), 6u);
  EXPECT_EQ(s.output, "f");
  EXPECT_EQ(s.regressors[1].transform, Transform::kAbsPow);
  EXPECT_DOUBLE_EQ(s.regressors[1].exponent, 0.2);
  EXPECT_EQ(s.regressors[2].transform, Transform::kLowPass);
  EXPECT_EQ(s.regressors[2].delays, std::vector<int>{0});  // the documented default
  EXPECT_EQ(s.regressors[3].transform, Transform::kTanh);
  EXPECT_DOUBLE_EQ(s.regressors[3].exponent, 0.5);
  EXPECT_EQ(s.regressors[4].transform, Transform::kClip);
  EXPECT_DOUBLE_EQ(s.regressors[4].exponent, 1.0);
  ASSERT_EQ(s.regressors[5].family.size(), 3u);  // a transform family
  EXPECT_EQ(s.regressors[5].family[1].transform, Transform::kTanh);
  EXPECT_DOUBLE_EQ(s.regressors[5].family[1].parameter, 0.1);
  EXPECT_EQ(s.regressors[5].family[2].transform, Transform::kSign);
  EXPECT_TRUE(s.stress.enabled);
  EXPECT_DOUBLE_EQ(s.stress.stretch, 2.0);
  EXPECT_DOUBLE_EQ(s.stress.force_bound, 3.0);
  EXPECT_EQ(s.max_factors, 3);
  EXPECT_EQ(s.max_candidates, 200000);
  EXPECT_EQ(s.strategy, Strategy::kFirst);
  EXPECT_EQ(s.selection, Selection::kCrossValidation);
  EXPECT_DOUBLE_EQ(s.selection_tolerance_percent, 5.0);
  EXPECT_EQ(s.selection_noise, SelectionNoise::kAuto);
  EXPECT_EQ(s.initial.size(), 2u);
  // The documented values are the built-in defaults.
  const SemSpec d = ParseSemSpec(
      "output = \"f\"\n[[regressor]]\nname = \"y\"\nsignal = \"f\"\n"
      "powers = [1]\ndelays = [1]\n",
      "min.toml");
  EXPECT_EQ(d.strategy, s.strategy);
  EXPECT_EQ(d.selection, s.selection);
  EXPECT_EQ(d.selection_noise, s.selection_noise);
  EXPECT_EQ(d.threshold_percent, s.threshold_percent);
  EXPECT_EQ(d.max_iterations, s.max_iterations);
  EXPECT_EQ(d.weighting, s.weighting);
  EXPECT_EQ(d.floor, s.floor);
  EXPECT_EQ(d.max_degree, s.max_degree);
  EXPECT_EQ(d.constant, s.constant);
  EXPECT_EQ(d.divergence_limit, s.divergence_limit);
}

TEST(SemSpecDocTest, UnknownSelectionIsRefusedWithItsLine) {
  const std::string text = DocumentedExample() + "";
  std::string bad = text;
  bad.replace(bad.find("\"cross_validation\""), 18, "\"aic\"");
  try {
    ParseSemSpec(bad, "x.toml");
    FAIL() << "accepted selection = \"aic\"";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown selection 'aic'"), std::string::npos) << e.what();
  }
}

TEST(SemSpecDocTest, SelectionNoiseTakesItsThreeValuesAndRefusesOthersWithTheLine) {
  const std::string text = DocumentedExample();
  const std::string key = "selection_noise = \"auto\"";
  const std::size_t at = text.find(key);
  ASSERT_NE(at, std::string::npos);
  const auto line =
      1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n');
  for (const auto& [value, noise] : {std::pair{"output", SelectionNoise::kOutput},
                                     std::pair{"equation", SelectionNoise::kEquation}}) {
    std::string t = text;
    t.replace(at, key.size(), std::string("selection_noise = \"") + value + "\"");
    EXPECT_EQ(ParseSemSpec(t, "x.toml").selection_noise, noise) << value;
  }
  std::string bad = text;
  bad.replace(at, key.size(), "selection_noise = \"white\"");
  try {
    ParseSemSpec(bad, "x.toml");
    FAIL() << "accepted selection_noise = \"white\"";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("x.toml:" + std::to_string(line) + ":", 0), 0u) << what;
    EXPECT_NE(what.find("unknown selection_noise 'white' (expected auto, output or equation)"),
              std::string::npos)
        << what;
  }
  bad.replace(bad.find("\"white\""), 7, "1");
  EXPECT_THROW(ParseSemSpec(bad, "x.toml"), InputError);  // not a string
}

TEST(ParseTermOfferTest, RefusesPowersAndDelaysNotOffered) {
  const SemSpec s = ParseSemSpec(DocumentedExample(), "candidate_spec.hpp");
  EXPECT_EQ(TermName(s, ParseTerm(s, "y(k-1)^2*a(k-1)^3")), "y(k-1)^2*a(k-1)^3");
  auto refuses = [&](const std::string& term, const std::string& why) {
    try {
      ParseTerm(s, term, "spec.toml", 7);
      ADD_FAILURE() << "accepted " << term;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("spec.toml:7"), std::string::npos) << e.what();
    }
  };
  refuses("y(k-1)^3", "power 3 not offered for 'y'");
  refuses("a(k)^4", "power 4 not offered for 'a'");
  refuses("y(k-1)*y(k-1)^2", "power 3 not offered for 'y'");  // merged factors
  refuses("e(k)^2", "power 2 not offered for 'e'");
  refuses("y(k-2)", "delay 2 not offered for 'y'");
  refuses("e(k-1)", "delay 1 not offered for 'e'");
}

SemIteration It(int iteration, std::size_t terms) {
  SemIteration it;
  it.iteration = iteration;
  it.terms.resize(terms);
  return it;
}

TEST(SemSelectionTest, BicOnCrossValidatedCostTradesTermsForCost) {
  const std::vector<SemIteration> its{It(0, 0), It(1, 1), It(2, 2), It(3, 3)};
  // Fold costs: a large drop with the 2nd term, then 1 % with the 3rd.
  const std::vector<std::vector<double>> cv{{1.0, 1.0}, {0.5, 0.5}, {0.1, 0.1}, {0.099, 0.099}};
  // 4 candidates, N = 100: the 3rd term must lower CV J by more than about
  // (ln(100) + 2 ln(4/6)) / 100 = 3.8 %.
  EXPECT_EQ(SelectByCrossValidation(its, cv, 100.0, 4.0), 2);
  // N = 2000: the threshold is about 0.34 %, so the 1 % drop is taken.
  EXPECT_EQ(SelectByCrossValidation(its, cv, 2000.0, 4.0), 3);
  // Picked among a million candidates, the 3rd term must pay 2 ln((1e6 - 2) / 3) = 25.4 more
  // than ln(N): the 1 % drop (2000 ln 0.99 = -20.1) no longer is enough.
  EXPECT_EQ(SelectByCrossValidation(its, cv, 2000.0, 1e6), 2);
  // A diverging cross-validation is never picked.
  std::vector<std::vector<double>> div = cv;
  div[2][1] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(SelectByCrossValidation(its, div, 100.0, 4.0), 3);
}

TEST(SemSelectionTest, CrossValidatedCostOfTheTrueStructureIsNearTheNoiseLevel) {
  // Output-error data: the free run of the true structure leaves only the measurement noise.
  const auto sys = test::RecoverySystems()[2];  // wei
  const std::vector<DataSet> id{test::RecoveryData(sys, test::Noise::kOutput, 3, 2000)};
  const SemSpec spec = ParseSemSpec(test::kRecoverySpec, "recovery.toml");
  const auto ch = ComputeScales(spec, id);
  std::vector<SemTerm> terms;
  for (const auto& t : sys.terms) terms.push_back(ParseTerm(spec, t));
  const std::vector<double> cv = CrossValidatedCost(spec, ch, terms, id, kSelectionFolds);
  ASSERT_EQ(cv.size(), static_cast<std::size_t>(kSelectionFolds));
  double total = 0.0;
  for (double v : cv) total += v;
  const double noise = sys.sigma * sys.sigma / (ch[0].scale * ch[0].scale);
  EXPECT_GT(total, 0.8 * noise);
  EXPECT_LT(total, 1.3 * noise);
  // Without the y(k-2)^2 term the cost is clearly higher.
  terms.erase(terms.begin() + 1);
  double fewer = 0.0;
  for (double v : CrossValidatedCost(spec, ch, terms, id, kSelectionFolds)) fewer += v;
  EXPECT_GT(fewer, 1.5 * total);
}

TEST(SemSelectionTest, EquationErrorNoiseIsWhitenedBeforeCrossValidation) {
  // billings, equation-error noise, N = 500, seed 17: the free-run residual is the noise through
  // 1 / (1 - 0.5 q^-1). Unfiltered, the cross-validated J preferred y(k-2)^3 over the true
  // y(k-2)^2; whitened by the fitted AR(1) filter it picks the true structure. The free-run
  // score as selection_noise = "output" keeps it (the default scores this noise by the one-step
  // error: EquationNoiseIsScoredByTheOneStepError).
  const auto sys = test::RecoverySystems()[0];
  const std::size_t n = 500;
  const std::vector<DataSet> ee{test::SuiteData(sys, test::Noise::kEquation, n, 17)};
  const SemSpec spec = ParseSemSpec(test::kRecoverySpec, "recovery.toml");
  SemSpec free_run = spec;
  free_run.selection_noise = SelectionNoise::kOutput;
  const SemResult a = Identify(free_run, ee, {}, SemOptions{});
  EXPECT_EQ(test::SelectedTerms(spec, a), sys.terms);
  const std::string key = "L(q) = 1 - ";
  const std::size_t at = a.selection_rule.find(key);
  ASSERT_NE(at, std::string::npos) << a.selection_rule;
  const double a1 = std::stod(a.selection_rule.substr(at + key.size()));  // true pole 0.5
  EXPECT_GT(a1, 0.35);
  EXPECT_LT(a1, 0.65);
  EXPECT_NE(a.selection_rule.find("the AR(1) whitening filter"), std::string::npos);
  EXPECT_FALSE(a.cv_one_step);
  // Output-error noise, default selection_noise (auto): the residual is white, the free run is
  // scored and its J is not filtered.
  const std::vector<DataSet> oe{test::SuiteData(sys, test::Noise::kOutput, n, 17)};
  const SemResult b = Identify(spec, oe, {}, SemOptions{});
  EXPECT_NE(b.selection_rule.find("L(q) = 1, the AR(0)"), std::string::npos) << b.selection_rule;
  EXPECT_FALSE(b.cv_one_step);
}

TEST(SemSelectionTest, EquationNoiseIsScoredByTheOneStepError) {
  // metamss_s3 (cubic output feedback 0.2 y(k-1)^3), equation-error noise, N = 1000, seed 7.
  // The noise reaches the free run through the cubic term, so the free run of the truth is not
  // the best free run: scored by the free run (selection_noise = "output"), the pick is the
  // truth plus y(k-2)*u(k-1). The default sees the coloured free-run residual and scores the
  // one-step prediction error, the likelihood of this noise: the truth.
  const auto& sys = test::RecoverySystemNamed("metamss_s3");
  const std::vector<DataSet> ee{test::SuiteData(sys, test::Noise::kEquation, 1000, 7)};
  const SemSpec spec = ParseSemSpec(test::kRecoverySpec, "recovery.toml");
  EXPECT_EQ(spec.selection_noise, SelectionNoise::kAuto);
  const SemResult a = Identify(spec, ee, {}, SemOptions{});
  EXPECT_EQ(test::SelectedTerms(spec, a), sys.terms);
  EXPECT_TRUE(a.cv_one_step);
  EXPECT_NE(a.selection_rule.find("cross-validation of the one-step prediction error"),
            std::string::npos)
      << a.selection_rule;
  EXPECT_NE(a.selection_rule.find("% of the one-step one is unpredictable from its own past"),
            std::string::npos)
      << a.selection_rule;
  EXPECT_NE(a.selection_rule.find("L(q) = 1 - "), std::string::npos) << a.selection_rule;
  SemSpec free_run = spec;
  free_run.selection_noise = SelectionNoise::kOutput;
  const SemResult b = Identify(free_run, ee, {}, SemOptions{});
  EXPECT_FALSE(b.cv_one_step);
  EXPECT_NE(b.selection_rule.find("refined free-run J"), std::string::npos) << b.selection_rule;
  std::set<std::string> extra = test::SelectedTerms(spec, b);
  for (const std::string& t : sys.terms) EXPECT_EQ(extra.erase(t), 1u) << t;
  EXPECT_EQ(extra, std::set<std::string>{"y(k-2)*u(k-1)"});
  // Forced by the spec on output-error data, whose free-run residual is white: said so.
  SemSpec forced = spec;
  forced.selection_noise = SelectionNoise::kEquation;
  const auto& billings = test::RecoverySystemNamed("billings");
  const std::vector<DataSet> oe{test::SuiteData(billings, test::Noise::kOutput, 500, 17)};
  const SemResult c = Identify(forced, oe, {}, SemOptions{});
  EXPECT_TRUE(c.cv_one_step);
  EXPECT_NE(c.selection_rule.find("(noise in the equation: selection_noise = \"equation\")"),
            std::string::npos)
      << c.selection_rule;
}

TEST(SemSelectionTest, NoiseFreeDamperDataKeepTheFreeRunScore) {
  // The paper spec on 4 s of the reference damper's identification profile, no noise: the
  // residual is model mismatch, coloured in the free run and mostly predictable in the one-step
  // prediction too, so auto keeps the free-run score (the control-oriented one) and says why.
  SemSpec spec = LoadSemSpec(std::string(MRD_SOURCE_DIR) + "/host/specs/paper.toml");
  spec.selection = Selection::kCrossValidation;
  spec.drop_terms = spec.score_exchange = false;
  ASSERT_EQ(spec.selection_noise, SelectionNoise::kAuto);
  const std::vector<DataSet> data{test::DamperData("identification", 4001)};
  SemOptions o;
  o.max_iterations = 8;
  o.threads = 2;
  const SemResult a = Identify(spec, data, {}, o);
  EXPECT_FALSE(a.cv_one_step) << a.selection_rule;
  EXPECT_NE(a.selection_rule.find("refined free-run J"), std::string::npos) << a.selection_rule;
  const std::string why = "free run scored: ";
  const std::size_t at = a.selection_rule.find(why);
  ASSERT_NE(at, std::string::npos) << a.selection_rule;
  EXPECT_LT(std::stod(a.selection_rule.substr(at + why.size())), 100.0 * kEquationNoiseShare)
      << a.selection_rule;
  EXPECT_NE(a.selection_rule.find("model mismatch, not noise in the equation"), std::string::npos);
}

double SumOf(const std::vector<double>& v) {
  double t = 0.0;
  for (double x : v) t += x;
  return t;
}

// The rule's statement of the pick's moves under the score (Identify), moves as listed.
std::string MovedPickRule(int selected, const std::string& moves) {
  return "; then the pick changed while that lowers the score (iteration " +
         std::to_string(selected) + "): " + moves;
}

TEST(SemSelectionTest, PickedStructureDropsTermsWhileTheScoreFalls) {
  // linear2 (lightly damped), equation-error noise, N = 1000, seed 7: the one-step start is the
  // truth plus y(k-1)^2*u(k-1), which its first iteration exchanges for y(k-1)^2*y(k-2) (J
  // 0.00640); no path drops that term (the truth's J is 0.00676), so the truth is on no path
  // and the pick carries it. Dropping it lowers the cross-validated score: the truth is selected
  // as a further iteration.
  // Scored by the free run (selection_noise = "output"). The default scores this noise by the
  // one-step error; there the pick is the one-step start itself, which drops its
  // y(k-1)^2*u(k-1) the same way.
  const auto& sys = test::RecoverySystemNamed("linear2");
  const std::vector<DataSet> ee{test::SuiteData(sys, test::Noise::kEquation, 1000, 7)};
  SemSpec spec = ParseSemSpec(test::kRecoverySpec, "recovery.toml");
  spec.selection_noise = SelectionNoise::kOutput;
  const SemResult a = Identify(spec, ee, {}, SemOptions{});
  EXPECT_EQ(test::SelectedTerms(spec, a), sys.terms);
  EXPECT_NE(a.selection_rule.find(MovedPickRule(a.selected, "dropped y(k-1)^2*y(k-2)")),
            std::string::npos)
      << a.selection_rule;
  ASSERT_GE(a.iterations.size(), 2u);
  const SemIteration& picked = a.iterations.back();
  EXPECT_EQ(picked.iteration, a.selected);
  ASSERT_EQ(picked.cv_j.size(), static_cast<std::size_t>(kSelectionFolds));
  // The search's own pick (the lowest score on the path) has one more term, a lower J and a
  // lower summed criterion: only the penalty of the extra term makes the drop pay.
  bool superset = false;
  for (const SemIteration& it : a.iterations) {
    if (it.iteration == a.selected || it.terms.size() != picked.terms.size() + 1) continue;
    std::set<std::string> names;
    for (const SemTerm& t : it.terms) names.insert(TermName(spec, t));
    if (!std::includes(names.begin(), names.end(), sys.terms.begin(), sys.terms.end())) continue;
    superset = true;
    EXPECT_LT(it.j, picked.j);
    EXPECT_LT(SumOf(it.cv_j), SumOf(picked.cv_j));
  }
  EXPECT_TRUE(superset);
  // The model file keeps it as the selected iteration, with the rule.
  const test::TempDir dir;
  SaveModelFile(MakeModelFile(spec, a), dir.File("m.json"));
  const ModelFile m = LoadModelFile(dir.File("m.json"));
  EXPECT_EQ(m.selected, a.selected);
  EXPECT_EQ(m.Iteration(m.selected).terms.size(), picked.terms.size());
  EXPECT_EQ(m.selection_rule, a.selection_rule);
  // Not under the tolerance rule (nor with validation data): the pick stands.
  SemSpec tol = spec;
  tol.selection = Selection::kTolerance;
  const SemResult b = Identify(tol, ee, {}, SemOptions{});
  EXPECT_EQ(b.selection_rule.find("pick changed"), std::string::npos) << b.selection_rule;
  EXPECT_EQ(b.selected, SelectIteration(b.iterations, tol.selection_tolerance_percent));
  // drop_terms = false: the search's pick, one term more than the truth.
  SemSpec keep = spec;
  keep.drop_terms = false;
  const SemResult c = Identify(keep, ee, {}, SemOptions{});
  EXPECT_EQ(c.selection_rule.find("dropped"), std::string::npos) << c.selection_rule;
  EXPECT_EQ(c.iterations.size() + 1, a.iterations.size());
  EXPECT_EQ(test::SelectedTerms(spec, c).size(), sys.terms.size() + 1);
}

TEST(SemSelectionTest, PickedStructureExchangesATermWhileTheScoreFalls) {
  // billings, output-error noise, N = 1000, seed 61: the noisy output biases the least squares,
  // and by their J the search prefers y(k-2)^3 to the true y(k-2)^2, so the truth is on no
  // path. With refined coefficients the truth has the lower J and the lower score: the pick
  // exchanges the term, a further iteration.
  const auto& sys = test::RecoverySystemNamed("billings");
  const std::vector<DataSet> oe{test::SuiteData(sys, test::Noise::kOutput, 1000, 61)};
  const SemSpec spec = ParseSemSpec(test::kRecoverySpec, "recovery.toml");
  const SemResult a = Identify(spec, oe, {}, SemOptions{});
  EXPECT_EQ(test::SelectedTerms(spec, a), sys.terms);
  EXPECT_NE(a.selection_rule.find(MovedPickRule(a.selected, "exchanged y(k-2)^3 for y(k-2)^2")),
            std::string::npos)
      << a.selection_rule;
  const SemIteration& picked = a.iterations.back();
  ASSERT_EQ(picked.iteration, a.selected);
  ASSERT_EQ(picked.cv_j.size(), static_cast<std::size_t>(kSelectionFolds));
  // score_exchange = false: the search's pick, the misfit of the true size; both its refined
  // J and its score are above the truth's.
  SemSpec keep = spec;
  keep.score_exchange = false;
  const SemResult b = Identify(keep, oe, {}, SemOptions{});
  EXPECT_EQ(b.selection_rule.find("pick changed"), std::string::npos) << b.selection_rule;
  ASSERT_EQ(b.iterations.size() + 1, a.iterations.size());
  const auto chosen =
      std::find_if(b.iterations.begin(), b.iterations.end(),
                   [&](const SemIteration& it) { return it.iteration == b.selected; });
  ASSERT_NE(chosen, b.iterations.end());
  ASSERT_EQ(chosen->terms.size(), sys.terms.size());
  EXPECT_NE(test::SelectedTerms(spec, b), sys.terms);
  EXPECT_GT(chosen->j, picked.j);
  EXPECT_GT(SumOf(chosen->cv_j), SumOf(picked.cv_j));  // same size: the score's order
  // The truth is on no path.
  for (const SemIteration& it : b.iterations) {
    std::set<std::string> names;
    for (const SemTerm& t : it.terms) names.insert(TermName(spec, t));
    EXPECT_NE(names, std::set<std::string>(sys.terms.begin(), sys.terms.end()));
  }
}

TEST(SemSelectionTest, ModelFileStatesTheRuleAndValidationStillWins) {
  const auto sys = test::RecoverySystems()[0];
  const std::vector<DataSet> id{test::RecoveryData(sys, test::Noise::kOutput, 5, 1000)};
  const std::vector<DataSet> val{test::RecoveryData(sys, test::Noise::kOutput, 6, 1000)};
  const SemSpec spec = ParseSemSpec(test::kRecoverySpec, "recovery.toml");
  SemOptions o;
  o.max_iterations = 8;
  const SemResult a = Identify(spec, id, {}, o);
  const std::string ja = ModelFileToJson(MakeModelFile(spec, a));
  const std::string rule = std::to_string(kSelectionFolds) +
                           "-fold cross-validation of the output-error refined free-run J";
  EXPECT_NE(ja.find(rule), std::string::npos) << ja;
  EXPECT_EQ(a.iterations.front().cv_j.size(), static_cast<std::size_t>(kSelectionFolds));
  const SemResult b = Identify(spec, id, val, o);
  EXPECT_EQ(b.selected, SelectIteration(b.iterations, spec.selection_tolerance_percent));
  EXPECT_NE(b.selection_rule.find("summed validation J"), std::string::npos) << b.selection_rule;
  EXPECT_TRUE(b.iterations.front().cv_j.empty());
  // selection = "tolerance": the old rule on the identification J.
  SemSpec tol = spec;
  tol.selection = Selection::kTolerance;
  const SemResult c = Identify(tol, id, {}, o);
  EXPECT_EQ(c.selected, SelectIteration(c.iterations, tol.selection_tolerance_percent));
  EXPECT_NE(c.selection_rule.find("identification J is within"), std::string::npos);
}

}  // namespace
}  // namespace mrd::host
