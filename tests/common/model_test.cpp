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
    const double ref = 0.6 * y1 + 0.3 * std::pow(std::fabs(vn), 0.6) * en * en * sgn - 0.01 -
                       0.05 * y2 * y2;
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

}  // namespace
}  // namespace mrd
