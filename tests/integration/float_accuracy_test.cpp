// Issue 11: the firmware's float code path (MRD_REAL=float; BasicModelRuntime<float>,
// BasicInverter<float>) against the double one, on the compiled-in table over the validation
// sets V1-V3 (the profiles driving the simulated Spencer damper, as `mrd generate`). Both
// instantiations are in every build, so this runs in the double build too.
//
// Tolerances are first-order rounding-error bounds (Higham-style), computed per sample from
// float's unit roundoff u = eps/2 and the model's magnitudes; nothing is fitted to the result:
//   local(k)  = scale_f * (gamma * S(k) + n eta),   S(k) = sum_i |theta_i t_i(k)| + |y(k)|,
//               gamma = n u / (1 - n u),  n = num_terms + 4 * (largest term degree) + 8
//               (input rounding and normalisation, pow, the products, theta, the sum,
//               denormalisation); eta = float's smallest subnormal, the absolute error of an
//               operation that underflows (a force decaying at 0 V and v = 0 in V2);
//   free run  B(k) = local(k) + rho(k) B(k-1), rho(k) = sum over terms of |d y(k) / d y(k-1)|
//               at the double trajectory (the model's sensitivity to its fed-back output);
//   inversion |dE| <= scale_E * (local(k) / scale_f + u |y_d| + tol_inv) / |dy/de| at the
//               double root + the root polishing tolerance (4 eps |e|): the demand's error
//               through the slope of the model in e (its conditioning). tol_inv is the
//               inverter's own residual tolerance, 64 eps_T (|y_d| + sum_j |a_j| emax^j), under
//               which any candidate counts as a root and the one nearest the previous command
//               wins (in float that admits about 1e-2 N of force, so the command may hold).
//               Where the model is not monotone the two precisions may pick different roots;
//               the float one must then still be an inverse: its force under the double model
//               equals the demand within local + scale_f tol_inv.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "mrd/common/model.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/inverter.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "sem_test_util.hpp"

namespace mrd {
namespace {

using firmware::BasicInverter;
using firmware::BasicModelRuntime;

constexpr double kU = static_cast<double>(std::numeric_limits<float>::epsilon()) / 2.0;  // u

struct Figures {
  double max_force_error = 0.0;  // free run, same command sequence [N]
  double peak_force = 0.0;       // [N]
  double max_force_bound = 0.0;  // [N]
  double max_local_error = 0.0;  // one step on the same (rounded) history [N]
  double max_e_error = 0.0;      // inversion on the same history, same root [V]
  double max_e_bound_ratio = 0.0;
  int root_choice_differs = 0;  // non-monotone state, another admissible root chosen
  int samples = 0;
  double loop_max_e_error = 0.0;  // closed loop (each precision on its own state) [V]
  double loop_max_force_error = 0.0;
  std::vector<double> e_errors, loop_e_errors;  // per sample, for percentiles
};

double Percentile99(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

// n for the model (see the file comment).
double Operations(const Model& m) {
  int max_degree = 0;
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    int d = 0;
    for (const Factor& f : m.terms[i].active()) d += f.power;
    max_degree = std::max(max_degree, d);
  }
  return m.num_terms + 4.0 * max_degree + 8.0;
}

// S(k) = sum_i |theta_i t_i| on the current sample (normalised), and rho(k) = sum_i
// |d(theta_i t_i) / d y(k-1)| for identity output regressors at delay 1.
void Magnitudes(const Model& m, const RegressorHistory& h, double* s, double* rho) {
  *s = 0.0;
  *rho = 0.0;
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    const Term& term = m.terms[i];
    *s += std::fabs(m.coefficients[i] * TermValue(term, h));
    for (std::size_t j = 0; j < term.num_factors; ++j) {
      const Factor& f = term.factors[j];
      if (m.regressors[f.regressor].channel != m.output_channel) continue;
      double d = std::fabs(m.coefficients[i]) * f.power *
                 std::pow(std::fabs(h.value(f.regressor, f.delay)), f.power - 1);
      for (std::size_t g = 0; g < term.num_factors; ++g) {
        if (g == j) continue;
        const Factor& o = term.factors[g];
        d *= std::pow(std::fabs(h.value(o.regressor, o.delay)), o.power);
      }
      *rho += d;
    }
  }
}

Figures Compare(const CoefficientTable& table, const host::DataSet& data) {
  const Model& m = table.model;
  const double n = Operations(m);
  const double gamma = n * kU / (1.0 - n * kU);
  const double eta = static_cast<double>(std::numeric_limits<float>::denorm_min());
  const double scale_f = m.scales[m.output_channel].scale;
  const double scale_e = m.scales[table.input_channel].scale;
  const std::size_t in = table.input_channel, out = m.output_channel;
  const int v_ch = m.ChannelIndex("v");

  BasicModelRuntime<double> ref;   // double, free run
  BasicModelRuntime<float> run32;  // float, free run on the same commands
  BasicInverter<double> inv64;
  BasicInverter<float> inv32;
  // float on the double trajectory, rounded: local errors only.
  const BasicModel<float> m32 = ModelAs<float>(m);
  BasicModelRunner<float> seeded(m32);
  BasicModelRuntime<double> loop64;  // closed loop, force tracking of the damper's force
  BasicModelRuntime<float> loop32;
  EXPECT_EQ(ref.Configure(table), Error::kOk);
  EXPECT_EQ(run32.Configure(table), Error::kOk);
  EXPECT_EQ(inv64.Configure(table), Error::kOk);
  EXPECT_EQ(inv32.Configure(table), Error::kOk);
  EXPECT_EQ(loop64.Configure(table), Error::kOk);
  EXPECT_EQ(loop32.Configure(table), Error::kOk);

  const auto& v = data.Column("v");
  const auto& x = data.Column("x");
  const auto& E = data.Column("E");
  const auto& f = data.Column("f");
  Figures fig;
  double bound = 0.0;  // B(k-1)
  double E64 = 0.0;
  float E32 = 0.0f;
  std::array<float, kMaxChannels> raw{};
  for (std::size_t k = 0; k < data.rows(); ++k) {
    const auto v32 = static_cast<float>(v[k]), x32 = static_cast<float>(x[k]);
    // Free run with the profile's command.
    ref.Begin(v[k], x[k]);
    const double fd = ref.Finish(E[k]);
    double s = 0.0, rho = 0.0;
    Magnitudes(m, ref.history(), &s, &rho);  // the sample as evaluated (output read at d >= 1)
    const double y = std::fabs(fd - m.scales[out].offset) / scale_f;
    const double local = scale_f * (gamma * (s + y) + n * eta);
    bound = local + rho * bound;
    const auto ff = static_cast<double>(run32.Step(v32, x32, static_cast<float>(E[k])));
    fig.max_force_error = std::max(fig.max_force_error, std::fabs(ff - fd));
    fig.max_force_bound = std::max(fig.max_force_bound, bound);
    fig.peak_force = std::max(fig.peak_force, std::fabs(fd));
    EXPECT_LE(std::fabs(ff - fd), bound) << data.path << " k=" << k;

    // One step on the rounded double history: forward and inversion.
    if (v_ch >= 0) raw[static_cast<std::size_t>(v_ch)] = v32;
    raw[in] = 0.0f;
    seeded.Begin(raw);
    seeded.SetInput(in, static_cast<float>(E[k]));
    const double local_error = std::fabs(static_cast<double>(seeded.Evaluate()) - fd);
    fig.max_local_error = std::max(fig.max_local_error, local_error);
    EXPECT_LE(local_error, local) << data.path << " k=" << k;
    // Demand: the double model's force at the profile's command (reachable), inverted as it is
    // (velocity 0: no dissipative direction, so a demand against v is not sent to E_min).
    const auto s64 = inv64.Solve(ref.history(), fd, 0.0);
    const auto s32 = inv32.Solve(seeded.history(), static_cast<float>(fd), 0.0f);
    const auto a = inv64.Polynomial(ref.history());
    const double emax = std::fmax(std::fabs(inv64.e_min()), std::fabs(inv64.e_max())) / scale_e;
    double magnitude = std::fabs(fd - m.scales[out].offset) / scale_f, power = 1.0;
    for (int j = 0; j <= inv64.degree(); ++j) {
      magnitude += std::fabs(a[static_cast<std::size_t>(j)]) * power;
      power *= emax;
    }
    const double tol_inv = 64.0 * 2.0 * kU * magnitude;  // BasicInverter<float>::Solve
    const double e_star = s64.E / scale_e;
    double slope = 0.0;  // dy/de at the double root
    for (int j = inv64.degree(); j >= 1; --j) {
      slope = slope * e_star + j * a[static_cast<std::size_t>(j)];
    }
    const double e_tol = scale_e * ((local / scale_f + kU * std::fabs(fd) / scale_f + tol_inv) /
                                        std::max(std::fabs(slope), 1e-300) +
                                    4.0 * 2.0 * kU);
    const double de = std::fabs(static_cast<double>(s32.E) - s64.E);
    EXPECT_TRUE(s64.reachable) << data.path << " k=" << k;
    fig.e_errors.push_back(de);
    if (de <= e_tol) {
      fig.max_e_error = std::max(fig.max_e_error, de);
      fig.max_e_bound_ratio = std::max(fig.max_e_bound_ratio, de / e_tol);
    } else {
      // Another root of a non-monotone polynomial: must still be an inverse.
      ++fig.root_choice_differs;
      double y32 = 0.0;
      const double e32 = static_cast<double>(s32.E) / scale_e;
      for (int j = inv64.degree(); j >= 0; --j) y32 = y32 * e32 + a[static_cast<std::size_t>(j)];
      EXPECT_LE(std::fabs(m.scales[out].offset + scale_f * y32 - fd), local + scale_f * tol_inv)
          << data.path << " k=" << k << " E64=" << s64.E << " E32=" << s32.E;
    }
    // Complete the rounded sample with the double force.
    seeded.Finish(static_cast<float>(fd));

    // Closed loop: each precision tracks the damper's force on its own state.
    loop64.Begin(v[k], x[k]);
    E64 = inv64.Solve(loop64.history(), f[k], v[k]).E;
    const double f64 = loop64.Finish(E64);
    loop32.Begin(v32, x32);
    E32 = inv32.Solve(loop32.history(), static_cast<float>(f[k]), v32).E;
    const float f32 = loop32.Finish(E32);
    fig.loop_e_errors.push_back(std::fabs(static_cast<double>(E32) - E64));
    fig.loop_max_e_error = std::max(fig.loop_max_e_error, fig.loop_e_errors.back());
    fig.loop_max_force_error =
        std::max(fig.loop_max_force_error, std::fabs(static_cast<double>(f32) - f64));
    ++fig.samples;
  }
  return fig;
}

class FloatAccuracyTest : public ::testing::TestWithParam<const char*> {};

TEST_P(FloatAccuracyTest, FloatPathWithinRoundingBoundsOfDouble) {
  const host::DataSet data = test::DamperData(GetParam());
  const CoefficientTable& table = firmware::kBuiltinTable;
  const Figures fig = Compare(table, data);
  ASSERT_GT(fig.samples, 10000);
  EXPECT_GT(fig.peak_force, 500.0);  // a real force trace
  // Different roots only where the model is not monotone in E: a small minority.
  EXPECT_LE(fig.root_choice_differs, fig.samples / 100);
  std::printf(
      "float vs double, %s (%d samples, built-in table): free-run force max |dF| %.3g N = "
      "%.3g of peak %.0f N (bound %.3g N); one step %.3g N; inversion max |dE| %.3g V, "
      "99th percentile %.3g V (<= %.2f of its bound; %d samples chose another root); closed "
      "loop tracking the damper force: max |dE| %.3g V, 99th percentile %.3g V, max |dF| "
      "%.3g N\n",
      GetParam(), fig.samples, fig.max_force_error, fig.max_force_error / fig.peak_force,
      fig.peak_force, fig.max_force_bound, fig.max_local_error, fig.max_e_error,
      Percentile99(fig.e_errors), fig.max_e_bound_ratio, fig.root_choice_differs,
      fig.loop_max_e_error, Percentile99(fig.loop_e_errors), fig.loop_max_force_error);
  RecordProperty("max_force_error_N", std::to_string(fig.max_force_error));
  RecordProperty("max_e_error_V", std::to_string(fig.max_e_error));
}

INSTANTIATE_TEST_SUITE_P(ValidationSets, FloatAccuracyTest, ::testing::Values("v1", "v2", "v3"));

}  // namespace
}  // namespace mrd
