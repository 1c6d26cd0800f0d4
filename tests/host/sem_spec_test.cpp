// Candidate spec parsing, term algebra and candidate generation.
#include <gtest/gtest.h>

#include <string>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host {
namespace {

std::string PaperSpecPath() { return std::string(MRD_SOURCE_DIR) + "/host/specs/paper.toml"; }

constexpr const char* kSmall = R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
transform = "identity"
powers = [1]
delays = [1]
[[regressor]]
name = "s"
signal = "u"
transform = "sign"
powers = [1, 2]
delays = [0]
)";

// Expects ParseSemSpec(text) to throw InputError at `line` with `what` in the message.
void ExpectError(const std::string& text, std::size_t line, const std::string& what) {
  try {
    ParseSemSpec(text, "bad.toml");
    FAIL() << "no error for " << what;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "bad.toml");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(SemSpecTest, PaperSpecHas1551Candidates) {
  const SemSpec spec = LoadSemSpec(PaperSpecPath());
  EXPECT_EQ(spec.output, "f");
  EXPECT_EQ(spec.regressors.size(), 4u);
  // (1+2x)(1+4x)(1+10x)^2(1+x)^2 truncated at x^3, minus the constant: 28 + 281 + 1242.
  EXPECT_EQ(GenerateCandidates(spec).size(), 1551u);
}

TEST(SemSpecTest, SignSquaredCollapses) {
  const SemSpec spec = ParseSemSpec(kSmall, "small.toml");
  // y(k-1), s(k), y(k-1)*s(k); s^2 = 1 is the constant (not offered) and y*s^2 = y.
  const auto c = GenerateCandidates(spec);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(TermName(spec, c[0]), "y(k-1)");
  EXPECT_EQ(TermName(spec, c[1]), "s(k)");
  EXPECT_EQ(TermName(spec, c[2]), "y(k-1)*s(k)");
}

TEST(SemSpecTest, AbsPowersOfOneSignalMerge) {
  const std::string text = std::string(kSmall) + R"([[regressor]]
name = "a"
signal = "u"
transform = "abs_pow"
exponent = 0.5
powers = [1, 2]
[[regressor]]
name = "b"
signal = "u"
transform = "abs_pow"
exponent = 1.0
powers = [1]
[limits]
max_factors = 2
)";
  const SemSpec spec = ParseSemSpec(text, "t.toml");
  // |u|^0.5 squared equals |u|^1: one of them is skipped; s*|u| equals u... not offered.
  EXPECT_EQ(TermKey(spec, ParseTerm(spec, "a(k)^2")), TermKey(spec, ParseTerm(spec, "b(k)")));
  EXPECT_EQ(TermKey(spec, ParseTerm(spec, "s(k)^2*y(k-1)")),
            TermKey(spec, ParseTerm(spec, "y(k-1)")));
  const auto c = GenerateCandidates(spec);
  int count_abs1 = 0;
  for (const auto& t : c) {
    if (TermKey(spec, t) == TermKey(spec, ParseTerm(spec, "b(k)"))) ++count_abs1;
  }
  EXPECT_EQ(count_abs1, 1);
}

TEST(SemSpecTest, ParseTermRoundTrips) {
  const SemSpec spec = LoadSemSpec(PaperSpecPath());
  const SemTerm t = ParseTerm(spec, "u2(k-1)^3 * y(k-1)^2*u1(k)");
  EXPECT_EQ(TermName(spec, t), "y(k-1)^2*u1(k)*u2(k-1)^3");
  EXPECT_EQ(ParseTerm(spec, TermName(spec, t)), t);
  EXPECT_THROW(ParseTerm(spec, "w(k)"), InputError);
  EXPECT_THROW(ParseTerm(spec, "y(k)"), InputError);  // delay 0 not offered
  EXPECT_THROW(ParseTerm(spec, "y(k-1)^"), InputError);
}

TEST(SemSpecTest, BadPowerNamesLine) {
  std::string t = kSmall;
  t.replace(t.find("powers = [1, 2]"), 15, "powers = [0, 2]");
  ExpectError(t, 12, "bad power 0");
  t = kSmall;
  t.replace(t.find("powers = [1, 2]"), 15, "powers = [1, 17]");
  ExpectError(t, 12, "bad power 17");
  t = kSmall;
  t.replace(t.find("powers = [1, 2]"), 15, "powers = [1.5]");
  ExpectError(t, 12, "bad power");
}

TEST(SemSpecTest, OutputAtDelayZeroRejected) {
  std::string t = kSmall;
  t.replace(t.find("delays = [1]"), 12, "delays = [0, 1]");
  ExpectError(t, 2, "delays >= 1");
}

TEST(SemSpecTest, EmptyCandidateSetRejected) {
  // Only sign(u)^2 = 1 (the constant, not offered).
  const SemSpec spec = ParseSemSpec(R"(output = "y"
[[regressor]]
name = "s"
signal = "u"
transform = "sign"
powers = [2]
)",
                                    "empty.toml");
  try {
    GenerateCandidates(spec);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "empty.toml");
    EXPECT_NE(std::string(e.what()).find("empty candidate set"), std::string::npos);
  }
}

TEST(SemSpecTest, MalformedTomlNamesLine) {
  ExpectError("output = \"y\"\n[[regressor]\nname = 1\n", 2, "");
}

TEST(SemSpecTest, UnknownKeyAndTransformRejected) {
  std::string t = kSmall;
  t.replace(t.find("transform = \"sign\""), 18, "transform = \"cosh\"");
  ExpectError(t, 11, "unknown transform 'cosh'");
  ExpectError(std::string(kSmall) + "[limits]\nmax_terms = 3\n", 15, "unknown key 'max_terms'");
}

constexpr const char* kLowPass = R"([[regressor]]
name = "lp"
signal = "u"
transform = "low_pass"
tau = 6.0
powers = [1, 2]
delays = [0, 1]
)";

TEST(SemSpecTest, LowPassIsItsOwnSignal) {
  const SemSpec s = ParseSemSpec(std::string(kSmall) + kLowPass, "lp.toml");
  ASSERT_EQ(s.regressors.size(), 3u);
  EXPECT_EQ(s.regressors[2].transform, Transform::kLowPass);
  EXPECT_EQ(s.regressors[2].exponent, 6.0);
  // lp(k)^2 is not 1 (unlike sign^2) and not u^2: it stays a candidate of its own.
  const SemTerm lp2 = ParseTerm(s, "lp(k)^2", "", 0);
  const SemTerm s2 = ParseTerm(s, "s(k)^2", "", 0);
  EXPECT_NE(TermKey(s, lp2), TermKey(s, s2));
  EXPECT_NE(TermKey(s, lp2), TermKey(s, SemTerm{}));
}

TEST(SemSpecTest, BadLowPassRejected) {
  const std::string base = std::string(kSmall) + kLowPass;
  std::string t = base;
  t.replace(t.find("tau = 6.0\n"), 10, "");
  ExpectError(t, 14, "needs 'tau'");
  t = base;
  t.replace(t.find("tau = 6.0"), 9, "tau = -1.0");
  ExpectError(t, 18, "'tau' must be in");
  ExpectError(std::string(kSmall).replace(std::string(kSmall).find("delays = [0]"), 12,
                                          "delays = [0]\ntau = 3.0"),
              8, "only valid with transform = \"low_pass\"");
  t = kSmall;
  t.replace(t.find("transform = \"identity\""), 22, "transform = \"low_pass\"\ntau = 2.0");
  ExpectError(t, 2, "input signals only");
}

TEST(SemSpecTest, MissingFileIsInputError) {
  EXPECT_THROW(LoadSemSpec("/nonexistent/spec.toml"), InputError);
}

}  // namespace
}  // namespace mrd::host
