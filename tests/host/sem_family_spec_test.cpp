// Issue 15: the spec key 'family' (candidate_spec.hpp) and the model file's "family" section: what
// parses, and a clear error (file, line, reason) for every bad form.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem_family.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

// Line 1 output, lines 2-6 the y regressor, line 7 [[regressor]] a, line 10 its family.
std::string Spec(const std::string& family_lines, const std::string& extra = "") {
  return std::string(R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
powers = [1]
delays = [1]
[[regressor]]
name = "a"
signal = "u"
)") + family_lines +
         "\npowers = [1]\n" + extra;
}

void ExpectError(const std::string& text, std::size_t line, const std::string& what) {
  try {
    ParseSemSpec(text, "fam.toml");
    FAIL() << "no error for " << what;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "fam.toml");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(SemFamilySpecTest, ParsesMembersInOrderAndStartsAtTheFirst) {
  const SemSpec s =
      ParseSemSpec(Spec(R"(family = [{transform = "abs_pow", exponent = 0.5}, {transform = "sign"},
          {transform = "tanh", scale = 0.1}, {transform = "clip", limit = 0.5},
          {transform = "low_pass", tau = 4.0}, {transform = "identity"}])"),
                   "fam.toml");
  const auto& f = s.regressors[1].family;
  ASSERT_EQ(f.size(), 6u);
  EXPECT_EQ(f[0].transform, Transform::kAbsPow);
  EXPECT_DOUBLE_EQ(f[0].parameter, 0.5);
  EXPECT_EQ(f[0].line, 10u);
  EXPECT_EQ(f[2].line, 11u);
  EXPECT_EQ(f[4].transform, Transform::kLowPass);
  EXPECT_DOUBLE_EQ(f[4].parameter, 4.0);
  EXPECT_EQ(s.regressors[1].transform, Transform::kAbsPow);  // the first, until resolved
  EXPECT_DOUBLE_EQ(s.regressors[1].exponent, 0.5);
  EXPECT_EQ(FamilyCombinations(s).size(), 6u);
  const SemSpec r = ResolveFamilies(s, {f[2]});
  EXPECT_TRUE(r.regressors[1].family.empty());
  EXPECT_EQ(r.regressors[1].transform, Transform::kTanh);
  EXPECT_DOUBLE_EQ(r.regressors[1].exponent, 0.1);
  EXPECT_EQ(TransformLabel(f[2]), "tanh(scale=0.1)");
  EXPECT_EQ(TransformLabel(f[1]), "sign");
}

TEST(SemFamilySpecTest, CombinationsMultiplyAcrossRegressors) {
  const std::string second = R"([[regressor]]
name = "b"
signal = "w"
family = [{transform = "sign"}, {transform = "tanh", scale = 1.0}]
powers = [1]
)";
  const SemSpec s = ParseSemSpec(
      Spec(
          R"(family = [{transform = "abs_pow", exponent = 0.2}, {transform = "abs_pow", exponent = 0.5},
                       {transform = "identity"}])",
          second),
      "fam.toml");
  const auto c = FamilyCombinations(s);
  ASSERT_EQ(c.size(), 6u);  // the first family varies slowest
  EXPECT_DOUBLE_EQ(c[1][0].parameter, 0.2);
  EXPECT_EQ(c[1][1].transform, Transform::kTanh);
  EXPECT_DOUBLE_EQ(c[2][0].parameter, 0.5);
  EXPECT_EQ(c[5][0].transform, Transform::kIdentity);
}

TEST(SemFamilySpecTest, BadFamiliesAreRefusedWithTheirLine) {
  ExpectError(Spec("family = []"), 10, "'family' must not be empty");
  ExpectError(Spec(R"(family = "tanh")"), 10, "must be an array of inline tables");
  ExpectError(Spec(R"(family = ["tanh"])"), 10, "must be inline tables");
  ExpectError(Spec(R"(family = [{scale = 0.1}])"), 10, "needs a 'transform'");
  ExpectError(Spec(R"(family = [{transform = "cube"}])"), 10, "unknown transform 'cube'");
  ExpectError(Spec(R"(family = [{transform = "tanh"}])"), 10, "\"tanh\" needs 'scale'");
  ExpectError(Spec(R"(family = [{transform = "abs_pow", exponent = -1.0}])"), 10,
              "'exponent' in 'family' must be > 0");
  ExpectError(Spec(R"(family = [{transform = "low_pass", tau = 2e6}])"), 10, "(0, 1e+06]");
  ExpectError(Spec(R"(family = [{transform = "sign", scale = 0.1}])"), 10,
              "'scale' is not a parameter of transform \"sign\"");
  ExpectError(Spec(R"(family = [{transform = "tanh", scale = 0.1, colour = 1}])"), 10,
              "unknown key 'colour' in a 'family' member");
  ExpectError(Spec(R"(family = [{transform = "tanh", scale = 0.1},
  {transform = "tanh", scale = 0.1}])"),
              11, "duplicate member in 'family'");
  ExpectError(Spec(R"(transform = "sign"
family = [{transform = "tanh", scale = 0.1}])"),
              7, "'family' replaces 'transform'");
  ExpectError(Spec(R"(family = [{transform = "abs_pow", exponent = 0.5}]
exponent = 0.5)"),
              7, "'family' replaces 'transform'");
  // On the output signal (whose regressors feed the simulation back).
  ExpectError(R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
family = [{transform = "tanh", scale = 0.1}, {transform = "identity"}]
powers = [1]
delays = [1]
)",
              2, "'family' is for input signals only");
}

TEST(SemFamilySpecTest, MoreThanSixteenCombinationsAreRefused) {
  const std::string four = R"(family = [{transform = "sign"}, {transform = "identity"},
  {transform = "tanh", scale = 0.1}, {transform = "tanh", scale = 0.2}])";
  const std::string second = R"([[regressor]]
name = "b"
signal = "w"
family = [{transform = "sign"}, {transform = "identity"}, {transform = "tanh", scale = 1.0},
          {transform = "clip", limit = 0.5}]
powers = [1]
)";
  EXPECT_EQ(FamilyCombinations(ParseSemSpec(Spec(four, second), "fam.toml")).size(), 16u);
  ExpectError(Spec(four, second + R"([[regressor]]
name = "c"
signal = "w"
family = [{transform = "sign"}, {transform = "identity"}]
powers = [1]
)"),
              19, "make 32 combinations > 16");
}

// The model file's family section: a bad one is refused naming the file.
TEST(SemFamilySpecTest, BadFamilySectionInModelFileIsRefused) {
  FamilyResult f;
  f.regressors = {"a"};
  f.rule = "lowest summed validation J of the selected iteration";
  f.combinations.push_back({{TransformChoice{Transform::kTanh, 0.1, 0}}, 0.5, 2, 2, 0.4});
  f.combinations.push_back({{TransformChoice{Transform::kSign, 1.0, 0}}, 0.25, 3, 3, 0.2});
  f.chosen = 1;
  const SemSpec spec = ParseSemSpec(Spec(R"(transform = "sign")"), "fam.toml");  // resolved
  const nlohmann::json good = FamilyToJson(f);
  const FamilyResult back = FamilyFromJson(good, spec, "m.json");
  ASSERT_EQ(back.combinations.size(), 2u);
  EXPECT_EQ(back.chosen, 1);
  EXPECT_EQ(back.rule, f.rule);
  EXPECT_EQ(back.combinations[0].members[0], f.combinations[0].members[0]);
  EXPECT_DOUBLE_EQ(back.combinations[1].score, 0.25);
  EXPECT_EQ(back.combinations[1].selected, 3);
  auto refused = [&](nlohmann::json j, const std::string& what) {
    try {
      FamilyFromJson(j, spec, "m.json");
      ADD_FAILURE() << "accepted: " << what;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), "m.json");
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  nlohmann::json j = good;
  j["chosen"] = 2;
  refused(j, "'chosen' = 2 is not a combination index");
  j = good;
  j["combinations"][0]["members"][0]["transform"] = "cube";
  refused(j, "unknown transform \"cube\"");
  j = good;
  j["combinations"][0]["members"][0].erase("scale");
  refused(j, "lacks 'scale'");
  j = good;
  j["combinations"][1]["members"].push_back({{"transform", "sign"}});
  refused(j, "one transform per family regressor");
  j = good;
  j["combinations"][1]["selected"] = -1;
  refused(j, "'selected' and 'terms' must be integers");
  j = good;
  j.erase("rule");
  refused(j, "lacks 'rule'");
  j = good;
  j["chosen"] = 0;  // the spec holds sign, not the tanh member
  refused(j, "the chosen tanh(scale=0.1) of 'a' is not the spec's sign");
  j = good;
  j["regressors"][0] = "b";
  refused(j, "'b' is not a regressor of the spec");
  // Through LoadModelFile: a model file whose family section is bad is not loaded.
  ModelFile m;
  m.spec = spec;
  m.channels = {{"y", 0.0, 1.0}, {"u", 0.0, 1.0}};
  m.iterations.push_back({});
  m.family = f;
  test::TempDir dir;
  nlohmann::json file = nlohmann::json::parse(ModelFileToJson(m));
  EXPECT_EQ(LoadModelFile(dir.Write("ok.json", file.dump())).family.chosen, 1);
  file["family"]["chosen"] = "one";
  const std::string bad = dir.Write("bad.json", file.dump());
  EXPECT_THROW(LoadModelFile(bad), InputError);
}

}  // namespace
}  // namespace mrd::host
