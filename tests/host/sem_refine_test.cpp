// The output-error refinement's free-run sensitivities (host/src/sem_evaluator.hpp) against
// central differences of the free run, through every output transform the spec offers, powers
// and products of delayed outputs (issue 15: the refinement's Jacobian is analytic).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "mrd/host/sem_spec.hpp"
#include "sem_evaluator.hpp"

namespace mrd::host::internal {
namespace {

// Output y fed back identically and through |y|^1.5, tanh(y/0.7) and clip(y, 0.9); input u.
SemSpec Spec() {
  const char* text = R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
powers = [1, 2, 3]
delays = [1, 2, 3]
[[regressor]]
name = "ya"
signal = "y"
transform = "abs_pow"
exponent = 1.5
powers = [1, 2]
delays = [1, 2]
[[regressor]]
name = "yt"
signal = "y"
transform = "tanh"
scale = 0.7
powers = [1, 2]
delays = [1, 2]
[[regressor]]
name = "yc"
signal = "y"
transform = "clip"
limit = 0.9
powers = [1]
delays = [1, 2, 3]
[[regressor]]
name = "u"
signal = "u"
powers = [1, 2]
delays = [0, 1, 2]
[limits]
max_factors = 3
constant = true
)";
  return ParseSemSpec(text, "refine-test.toml");
}

// A damped record: y follows a stable nonlinear system driven by uniform u.
DataSet Damped(std::size_t n) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  DataSet d;
  d.names = {"y", "u"};
  d.columns.assign(2, std::vector<double>(n, 0.0));
  auto& y = d.columns[0];
  auto& u = d.columns[1];
  for (std::size_t k = 0; k < n; ++k) {
    u[k] = uni(rng);
    if (k >= 2) {
      y[k] = 0.5 * y[k - 1] - 0.2 * std::tanh(y[k - 2] / 0.7) + 0.6 * u[k - 1] +
             0.1 * u[k - 1] * u[k - 1] + 0.02 * uni(rng);
    }
  }
  return d;
}

TEST(SemRefineTest, SensitivitiesEqualCentralDifferencesOfTheFreeRun) {
  const SemSpec spec = Spec();
  const std::vector<ChannelInfo> ch = {{"y", 0.0, 1.0}, {"u", 0.0, 1.0}};
  const DataSet d = Damped(400);
  const Evaluator ev(spec, ch, d);
  std::vector<SemTerm> terms;
  const std::vector<std::string> names = {"y(k-1)", "ya(k-2)",  "yt(k-1)*u(k-1)", "yc(k-3)",
                                          "y(k-1)^2*y(k-2)", "u(k-1)", "u(k-2)^2", "1"};
  for (const std::string& t : names) terms.push_back(ParseTerm(spec, t));
  Eigen::VectorXd theta(8);
  theta << 0.45, -0.1, 0.15, -0.05, 0.03, 0.6, 0.1, 0.01;
  const auto p = ev.Prepare(terms);
  const Record& rec = ev.record();
  const std::size_t a = rec.first, b = rec.y.size(), m = terms.size();
  std::vector<double> ys, e, sens;
  const double j = ev.FreeRun(p, theta, a, b, ys, &e, &sens);
  ASSERT_TRUE(std::isfinite(j));
  // Same cost and residual as the run without sensitivities.
  std::vector<double> e0;
  EXPECT_DOUBLE_EQ(ev.FreeRun(p, theta, a, b, ys, &e0), j);
  ASSERT_EQ(e0, e);
  ASSERT_EQ(sens.size(), (b - a) * m);
  double worst = 0.0, scale = 0.0;
  for (std::size_t c = 0; c < m; ++c) {
    const double h = 1e-6;
    Eigen::VectorXd tp = theta, tm = theta;
    tp(static_cast<Eigen::Index>(c)) += h;
    tm(static_cast<Eigen::Index>(c)) -= h;
    std::vector<double> ep, em;
    ASSERT_TRUE(std::isfinite(ev.FreeRun(p, tp, a, b, ys, &ep)));
    ASSERT_TRUE(std::isfinite(ev.FreeRun(p, tm, a, b, ys, &em)));
    for (std::size_t k = 0; k < b - a; ++k) {
      const double fd = -(ep[k] - em[k]) / (2.0 * h);  // d ysim / d theta = -d e / d theta
      worst = std::max(worst, std::fabs(fd - sens[k * m + c]));
      scale = std::max(scale, std::fabs(fd));
    }
  }
  EXPECT_GT(scale, 0.1);               // the output feedback made the columns non-trivial
  EXPECT_LT(worst, 1e-6 * scale) << "largest |analytic - central difference| " << worst;
}

TEST(SemRefineTest, TransformSlopesMatchTheirTransforms) {
  for (const auto& [t, e] : std::vector<std::pair<Transform, double>>{
           {Transform::kIdentity, 1.0}, {Transform::kAbsPow, 1.5}, {Transform::kAbsPow, 0.5},
           {Transform::kTanh, 0.7}, {Transform::kClip, 0.9}, {Transform::kSign, 1.0}}) {
    for (double s : {-1.3, -0.4, 0.2, 0.8, 1.6}) {
      const double h = 1e-6;
      const double fd = (ApplyTransform(t, e, s + h) - ApplyTransform(t, e, s - h)) / (2 * h);
      EXPECT_NEAR(TransformSlope(t, e, s), fd, 1e-6) << static_cast<int>(t) << " at " << s;
    }
  }
}

}  // namespace
}  // namespace mrd::host::internal
