#include "mrd/common/model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

namespace mrd {
namespace {

// Channels: 0 = v, 1 = E, 2 = f (output). Regressors: 0 = f, 1 = E, 2 = |v|^0.2, 3 = sign(v).
Model HandModel() {
  Model m;
  m.num_channels = 3;
  m.output_channel = 2;
  std::strcpy(m.channel_names[0].data(), "v");
  std::strcpy(m.channel_names[1].data(), "E");
  std::strcpy(m.channel_names[2].data(), "f");
  m.scales[0] = {0.0, 15.0};
  m.scales[1] = {0.0, 2.25};
  m.scales[2] = {10.0, 1500.0};
  m.num_regressors = 4;
  m.regressors[0] = {2, Transform::kIdentity, 1.0};
  m.regressors[1] = {1, Transform::kIdentity, 1.0};
  m.regressors[2] = {0, Transform::kAbsPow, 0.2};
  m.regressors[3] = {0, Transform::kSign, 1.0};
  m.num_terms = 4;
  m.terms[0].num_factors = 1;
  m.terms[0].factors[0] = {0, 1, 1};  // f(k-1)
  m.terms[1].num_factors = 3;
  m.terms[1].factors[0] = {2, 0, 3};  // |v(k)|^0.6
  m.terms[1].factors[1] = {1, 0, 2};  // E(k)^2
  m.terms[1].factors[2] = {3, 1, 1};  // sign(v(k-1))
  m.terms[2].num_factors = 0;         // constant
  m.terms[3].num_factors = 1;
  m.terms[3].factors[0] = {0, 2, 2};  // f(k-2)^2
  m.coefficients = {0.6, 0.3, -0.01, -0.05};
  return m;
}

TEST(ModelTest, HandModelIsValid) { EXPECT_EQ(HandModel().Validate(), Error::kOk); }

TEST(ModelTest, RunnerMatchesStraightforwardReference) {
  const Model m = HandModel();
  ModelRunner runner(m);
  std::vector<double> v, E, fn;  // fn: reference output, normalised
  fn = {0.0, 0.0};
  double worst = 0.0;
  for (int k = 0; k < 500; ++k) {
    v.push_back(12.0 * std::sin(0.05 * k));
    E.push_back(1.1 + std::sin(0.013 * k));
    const double vn = v[k] / 15.0, en = E[k] / 2.25;
    const double vprev = k > 0 ? v[k - 1] / 15.0 : 0.0;
    const double sgn = vprev > 0 ? 1.0 : (vprev < 0 ? -1.0 : 0.0);
    const double y1 = fn[fn.size() - 1], y2 = fn[fn.size() - 2];
    const double ref =
        0.6 * y1 + 0.3 * std::pow(std::fabs(vn), 0.6) * en * en * sgn - 0.01 - 0.05 * y2 * y2;
    fn.push_back(ref);
    const double raw[3] = {v[k], E[k], 0.0};
    const double got = runner.Step(raw);
    worst = std::max(worst, std::fabs(got - (ref * 1500.0 + 10.0)));
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(ModelTest, MaxDelayAndChannelIndex) {
  const Model m = HandModel();
  EXPECT_EQ(m.MaxDelay(), 2);
  EXPECT_EQ(m.ChannelIndex("E"), 1);
  EXPECT_EQ(m.ChannelIndex("x"), -1);
}

TEST(ModelTest, ValidateRejectsOutputAtDelayZero) {
  Model m = HandModel();
  m.terms[0].factors[0].delay = 0;
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
}

TEST(ModelTest, ValidateRejectsBadIndicesPowersAndValues) {
  Model m = HandModel();
  m.terms[1].factors[0].regressor = 9;
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
  m = HandModel();
  m.terms[1].factors[0].power = 0;
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
  m = HandModel();
  m.coefficients[2] = std::nan("");
  EXPECT_EQ(m.Validate(), Error::kNonFinite);
  m = HandModel();
  m.scales[0].scale = 0.0;
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
  m = HandModel();
  m.num_terms = kMaxTerms + 1;
  EXPECT_EQ(m.Validate(), Error::kCapacityExceeded);
  m = HandModel();
  m.regressors[2].exponent = -0.2;
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
}

TEST(ModelTest, TransformsHandleZero) {
  EXPECT_EQ(ApplyTransform(Transform::kAbsPow, 0.2, 0.0), 0.0);
  EXPECT_EQ(ApplyTransform(Transform::kSign, 1.0, 0.0), 0.0);
  EXPECT_EQ(ApplyTransform(Transform::kSign, 1.0, -3.0), -1.0);
  EXPECT_NEAR(ApplyTransform(Transform::kAbsPow, 0.5, -4.0), 2.0, 1e-15);
}

// Channels 0 = E, 1 = f (output); regressors 0 = f, 1 = low-pass of E (tau 4 samples).
Model LowPassModel() {
  Model m;
  m.num_channels = 2;
  m.output_channel = 1;
  std::strcpy(m.channel_names[0].data(), "E");
  std::strcpy(m.channel_names[1].data(), "f");
  m.scales[0] = {0.0, 2.0};
  m.scales[1] = {0.0, 100.0};
  m.num_regressors = 2;
  m.regressors[0] = {1, Transform::kIdentity, 1.0};
  m.regressors[1] = {0, Transform::kLowPass, 4.0};
  m.num_terms = 3;
  m.terms[0].num_factors = 1;
  m.terms[0].factors[0] = {0, 1, 1};  // f(k-1)
  m.terms[1].num_factors = 1;
  m.terms[1].factors[0] = {1, 0, 2};  // lp(E)(k)^2
  m.terms[2].num_factors = 1;
  m.terms[2].factors[0] = {1, 3, 1};  // lp(E)(k-3)
  m.coefficients = {0.5, 0.4, -0.2};
  return m;
}

TEST(ModelTest, LowPassRegressorIsARecursiveFilterFromZero) {
  const Model m = LowPassModel();
  ASSERT_EQ(m.Validate(), Error::kOk);
  ModelRunner runner(m);
  const double a = std::exp(-1.0 / 4.0);
  std::vector<double> lp;  // reference filter output
  double r = 0.0, y = 0.0, worst = 0.0;
  for (int k = 0; k < 300; ++k) {
    const double e = std::sin(0.07 * k) + (k % 17 == 0 ? 1.0 : 0.0);  // normalised E
    r = a * r + (1.0 - a) * e;
    lp.push_back(r);
    const double lp3 = k >= 3 ? lp[static_cast<std::size_t>(k - 3)] : 0.0;
    y = 0.5 * y + 0.4 * r * r - 0.2 * lp3;
    const double raw[2] = {2.0 * e, 0.0};
    worst = std::max(worst, std::fabs(runner.Step(raw) - 100.0 * y));
  }
  EXPECT_LT(worst, 1e-10);
}

TEST(ModelTest, LowPassSetInputReplacesTheSampleNotTheState) {
  const Model m = LowPassModel();
  ModelRunner a(m), b(m);
  for (int k = 0; k < 50; ++k) {
    const double raw[2] = {std::cos(0.1 * k), 0.0};
    a.Step(raw);
    b.Step(raw);
  }
  // Begin with one command then SetInput to another == Begin with the other directly.
  const double first[2] = {1.7, 0.0}, second[2] = {0.3, 0.0};
  a.Begin(first);
  a.SetInput(0, 0.3);
  b.Begin(second);
  EXPECT_EQ(a.Evaluate(), b.Evaluate());
  a.Finish(1.0);
  b.Finish(1.0);
  EXPECT_EQ(a.history().value(1, 0), b.history().value(1, 0));
}

TEST(ModelTest, ValidateRejectsBadLowPass) {
  Model m = LowPassModel();
  m.regressors[1].exponent = 0.0;
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
  m.regressors[1].exponent = 2.0 * kMaxLowPassTau;
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
  m = LowPassModel();
  m.regressors[0].transform = Transform::kLowPass;  // on the output channel
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
  m = LowPassModel();
  m.regressors[1].transform = static_cast<Transform>(6);
  EXPECT_EQ(m.Validate(), Error::kOutOfRange);
}

}  // namespace
}  // namespace mrd
