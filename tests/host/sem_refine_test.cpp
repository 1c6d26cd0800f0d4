// The output-error refinement's free-run sensitivities (host/src/sem/estimate/evaluator.hpp)
// against central differences of the free run, through every output transform the spec offers,
// powers and products of delayed outputs (issue 15: the refinement's Jacobian is analytic).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "sem/estimate/evaluator.hpp"

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

// A damped record: y follows a stable nonlinear system driven by uniform u, with equation
// noise; output_noise (amplitude) adds measurement noise to the recorded y as well.
DataSet Damped(std::size_t n, double output_noise = 0.0) {
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
  if (output_noise > 0.0) {
    for (double& v : y) v += output_noise * uni(rng);
  }
  return d;
}

TEST(SemRefineTest, SensitivitiesEqualCentralDifferencesOfTheFreeRun) {
  const SemSpec spec = Spec();
  const std::vector<ChannelInfo> ch = {{"y", 0.0, 1.0}, {"u", 0.0, 1.0}};
  const DataSet d = Damped(400);
  const Evaluator ev(spec, ch, d);
  std::vector<SemTerm> terms;
  const std::vector<std::string> names = {"y(k-1)",          "ya(k-2)", "yt(k-1)*u(k-1)", "yc(k-3)",
                                          "y(k-1)^2*y(k-2)", "u(k-1)",  "u(k-2)^2",       "1"};
  for (const std::string& t : names) terms.push_back(ParseTerm(spec, t));
  Eigen::VectorXd theta(8);
  theta << 0.45, -0.1, 0.15, -0.05, 0.03, 0.6, 0.1, 0.01;
  const auto p = ev.Prepare(terms);
  const Record& rec = ev.record();
  const std::size_t a = rec.first, b = rec.y.size(), m = terms.size();
  Evaluator::Scratch ys;
  std::vector<double> e, sens((b - a) * m);
  const double j = ev.FreeRun(p, theta, a, b, ys, &e, sens.data());
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
  EXPECT_GT(scale, 0.1);  // the output feedback made the columns non-trivial
  EXPECT_LT(worst, 1e-6 * scale) << "largest |analytic - central difference| " << worst;
}

TEST(SemRefineTest, TransformSlopesMatchTheirTransforms) {
  for (const auto& [t, e] : std::vector<std::pair<Transform, double>>{{Transform::kIdentity, 1.0},
                                                                      {Transform::kAbsPow, 1.5},
                                                                      {Transform::kAbsPow, 0.5},
                                                                      {Transform::kTanh, 0.7},
                                                                      {Transform::kClip, 0.9},
                                                                      {Transform::kSign, 1.0}}) {
    for (double s : {-1.3, -0.4, 0.2, 0.8, 1.6}) {
      const double h = 1e-6;
      const double fd = (ApplyTransform(t, e, s + h) - ApplyTransform(t, e, s - h)) / (2 * h);
      EXPECT_NEAR(TransformSlope(t, e, s), fd, 1e-6) << static_cast<int>(t) << " at " << s;
    }
  }
}

// Weighted one-step least squares of `terms` on the evaluator's record (the refinement's usual
// start; the weights are the free-run cost's).
std::vector<double> OneStepFit(const Evaluator& ev, const std::vector<SemTerm>& terms) {
  const Record& rec = ev.record();
  const auto rows = static_cast<Eigen::Index>(rec.y.size() - rec.first);
  Eigen::MatrixXd phi(rows, static_cast<Eigen::Index>(terms.size()));
  Eigen::VectorXd y(rows);
  for (Eigen::Index k = 0; k < rows; ++k) {
    const std::size_t row = rec.first + static_cast<std::size_t>(k);
    const double sw = std::sqrt(rec.w[row]);
    y(k) = sw * rec.y[row];
    for (std::size_t i = 0; i < terms.size(); ++i) {
      phi(k, static_cast<Eigen::Index>(i)) = sw * ev.Term(terms[i], rec.y, row);
    }
  }
  const Eigen::VectorXd th = phi.colPivHouseholderQr().solve(y);
  return {th.data(), th.data() + th.size()};
}

std::vector<SemTerm> Terms(const SemSpec& spec, const std::vector<std::string>& names) {
  std::vector<SemTerm> terms;
  for (const std::string& t : names) terms.push_back(ParseTerm(spec, t));
  return terms;
}

// Levenberg-Marquardt from the one-step fit ends at a stationary point of the free-run J: the
// decrease the Gauss-Newton model still promises there is negligible. Output noise biases the
// one-step fit, so the start is far from that point.
TEST(SemRefineTest, RefinementEndsAtAStationaryPointOfTheFreeRunCost) {
  const SemSpec spec = Spec();
  const std::vector<ChannelInfo> ch = {{"y", 0.0, 1.0}, {"u", 0.0, 1.0}};
  const std::vector<Evaluator> ev{{spec, ch, Damped(2000, 0.3)}};
  const auto terms = Terms(spec, {"y(k-1)", "yt(k-2)", "u(k-1)", "u(k-1)^2", "y(k-1)*u(k-1)"});
  std::vector<double> theta = OneStepFit(ev[0], terms);
  Evaluator::Scratch scratch;
  std::vector<double> e;
  const Record& rec = ev[0].record();
  const double j0 =
      ev[0].FreeRun(ev[0].Prepare(terms), Eigen::Map<const Eigen::VectorXd>(theta.data(), 5),
                    rec.first, rec.y.size(), scratch, &e);
  Jacobian jac;
  Eigen::VectorXd r;
  const double j = RefineFreeRun(ev, terms, &theta, &jac, &r);
  ASSERT_TRUE(std::isfinite(j0));
  ASSERT_TRUE(std::isfinite(j));
  EXPECT_LT(j, j0);  // output terms: the one-step fit is not the free-run optimum
  EXPECT_NEAR(r.squaredNorm(), j, 1e-12 * j);
  const Eigen::VectorXd g = jac.transpose() * r;
  const Eigen::MatrixXd a = jac.transpose() * jac;
  const double promised = g.dot(a.ldlt().solve(g));  // Newton decrement of the Gauss-Newton model
  EXPECT_LT(promised, 1e-6 * j) << "the refinement stopped short of the optimum";
}

// A structure without output terms: its free run is its one-step prediction, so the one-step
// least squares is already optimal and the refinement leaves it bit for bit.
TEST(SemRefineTest, StructureWithoutOutputTermsKeepsItsLeastSquares) {
  const SemSpec spec = Spec();
  const std::vector<ChannelInfo> ch = {{"y", 0.0, 1.0}, {"u", 0.0, 1.0}};
  const std::vector<Evaluator> ev{{spec, ch, Damped(2000)}};
  const auto terms = Terms(spec, {"u(k-1)", "u(k-1)^2", "u(k-2)", "1"});
  std::vector<double> theta = OneStepFit(ev[0], terms);
  const std::vector<double> start = theta;
  const double j = RefineFreeRun(ev, terms, &theta);
  ASSERT_TRUE(std::isfinite(j));
  EXPECT_EQ(theta, start);
}

}  // namespace
}  // namespace mrd::host::internal
