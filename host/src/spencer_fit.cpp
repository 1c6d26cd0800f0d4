// mrd fit-spencer's engine (spencer_fit.hpp): Ceres on the harness's RK4 Spencer plant.
#include "mrd/host/spencer_fit.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <mutex>
#include <numeric>
#include <random>
#include <stdexcept>
#include <thread>

#include "mrd/params/spencer_params_file.hpp"
#include "spencer_sensitivity.hpp"

namespace mrd::host {
namespace {

constexpr int kN = static_cast<int>(params::kSpencerFieldCount);  // 14

std::array<double, kN> ToArray(const SpencerParams& p) {
  SpencerParams copy = p;
  params::SpencerField f[params::kSpencerFieldCount];
  params::SpencerFields(&copy, f);
  std::array<double, kN> a{};
  for (int i = 0; i < kN; ++i) a[static_cast<std::size_t>(i)] = *f[i].value;
  return a;
}

SpencerParams FromArray(const double* a) {
  SpencerParams p;
  params::SpencerField f[params::kSpencerFieldCount];
  params::SpencerFields(&p, f);
  for (int i = 0; i < kN; ++i) *f[i].value = a[i];
  return p;
}

// Optimisation variables: theta = p / scale, scale = |spencer1997| (x0: 1 cm), so every
// variable is O(1) and Ceres' relative finite-difference steps suit all of them.
std::array<double, kN> Scale() {
  std::array<double, kN> s = ToArray(SpencerParams::Spencer1997());
  for (double& v : s) v = std::fabs(v) > 0.0 ? std::fabs(v) : 1.0;
  return s;
}

struct SimResidual {
  const FitRun* run;
  int substeps;
  double e_max;
  std::array<double, kN> scale;
  bool operator()(const double* theta, double* residual) const {
    double p[kN];
    for (int i = 0; i < kN; ++i) p[i] = theta[i] * scale[static_cast<std::size_t>(i)];
    const SpencerParams sp = FromArray(p);
    SpencerDamper d(sp, substeps);
    const std::vector<double>& x = run->x;
    const std::vector<double>& v = run->v;
    const std::size_t n = x.size();
    d.Reset(x[0], 0.0);
    residual[0] = d.Force(x[0], v[0]) - run->f[0];
    for (std::size_t k = 0; k + 1 < n; ++k) {
      const double e = std::clamp(run->E[k + 1], 0.0, e_max);  // as mrd generate
      const double f = d.Step(run->dt, x[k], v[k], x[k + 1], v[k + 1], e);
      if (!std::isfinite(f) || std::fabs(f) > 1e9) return false;
      residual[k + 1] = f - run->f[k + 1];
    }
    return true;
  }
};

FitRun Head(const FitRun& r, double seconds) {
  if (seconds <= 0.0) return r;
  const auto rows = std::min(r.x.size(), static_cast<std::size_t>(seconds / r.dt) + 1);
  FitRun h;
  h.name = r.name;
  h.dt = r.dt;
  const auto cut = [&](const std::vector<double>& c) {
    return std::vector<double>(c.begin(), c.begin() + static_cast<std::ptrdiff_t>(rows));
  };
  h.x = cut(r.x);
  h.v = cut(r.v);
  h.E = cut(r.E);
  h.f = cut(r.f);
  return h;
}

// The simulator's residuals with their exact Jacobian (forward sensitivities,
// spencer_sensitivity.hpp), the 14 columns split over `threads` threads (each thread simulates
// the state itself and propagates its share of the columns; column j's arithmetic does not
// depend on the split, so the result does not depend on the thread count).
class SimCost final : public ceres::CostFunction {
 public:
  SimCost(SimResidual sim, int rows, int threads) : sim_(sim), threads_(threads) {
    set_num_residuals(rows);
    mutable_parameter_block_sizes()->push_back(kN);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* theta = parameters[0];
    if (jacobians == nullptr || jacobians[0] == nullptr) return sim_(theta, residuals);
    double p[kN];
    for (int i = 0; i < kN; ++i) p[i] = theta[i] * sim_.scale[static_cast<std::size_t>(i)];
    const int t = std::max(1, std::min(threads_, kN));
    std::array<bool, kN> ok{};
    const auto work = [&](int k) {
      ok[static_cast<std::size_t>(k)] =
          SpencerSensitivity(p, *sim_.run, sim_.substeps, sim_.e_max, k * kN / t, (k + 1) * kN / t,
                             sim_.scale.data(), k == 0 ? residuals : nullptr, jacobians[0], kN);
    };
    std::vector<std::thread> pool;
    for (int k = 1; k < t; ++k) pool.emplace_back(work, k);
    work(0);
    for (std::thread& th : pool) th.join();
    return std::all_of(ok.begin(), ok.begin() + t, [](bool b) { return b; });
  }

 private:
  SimResidual sim_;
  int threads_;
};

// One Ceres solve from start over runs (Jacobians on jac_threads threads); returns the final
// cost (0.5 sum r^2), +inf when the start itself cannot be simulated.
double Solve(const std::vector<FitRun>& runs, const SpencerFitOptions& o, int iterations,
             int jac_threads, SpencerParams* p, int* iterations_done) {
  const std::array<double, kN> scale = Scale();
  SpencerParams lo, hi;
  SpencerFitBounds(&lo, &hi);
  const auto a = ToArray(*p), alo = ToArray(lo), ahi = ToArray(hi);
  std::array<double, kN> theta{};
  for (std::size_t i = 0; i < kN; ++i) theta[i] = std::clamp(a[i], alo[i], ahi[i]) / scale[i];
  ceres::Problem problem;
  for (const FitRun& r : runs) {
    problem.AddResidualBlock(new SimCost(SimResidual{&r, o.substeps, o.e_max, scale},
                                         static_cast<int>(r.x.size()), jac_threads),
                             nullptr, theta.data());
  }
  for (std::size_t i = 0; i < kN; ++i) {
    problem.SetParameterLowerBound(theta.data(), static_cast<int>(i), alo[i] / scale[i]);
    problem.SetParameterUpperBound(theta.data(), static_cast<int>(i), ahi[i] / scale[i]);
  }
  double initial = 0.0;
  if (!problem.Evaluate(ceres::Problem::EvaluateOptions(), &initial, nullptr, nullptr, nullptr) ||
      !std::isfinite(initial)) {
    *iterations_done = 0;
    return HUGE_VAL;
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  so.function_tolerance = 1e-7;
  so.parameter_tolerance = 1e-9;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  *iterations_done = static_cast<int>(summary.iterations.size());
  std::array<double, kN> out{};
  for (std::size_t i = 0; i < kN; ++i) out[i] = theta[i] * scale[i];
  *p = FromArray(out.data());
  return summary.final_cost;
}

// Runs job(i) for i in [0, n) on up to `threads` threads (results land by index, so the
// outcome does not depend on the scheduling).
void ParallelFor(int n, int threads, const std::function<void(int)>& job) {
  std::atomic<int> next{0};
  std::vector<std::thread> pool;
  const int t = std::max(1, std::min(threads, n));
  for (int k = 0; k < t; ++k) {
    pool.emplace_back([&] {
      for (int i = next++; i < n; i = next++) job(i);
    });
  }
  for (std::thread& th : pool) th.join();
}

}  // namespace

void SpencerFitBounds(SpencerParams* lo, SpencerParams* hi) {
  // Wide physical boxes (spencer_damper.hpp units); both presets lie inside.
  *lo = FromArray(std::array<double, kN>{0.1, 0.0, 0.01, 1.0, 0.0, 0.0, -50.0, 0.0, 0.0, 0.0, 0.0,
                                         1.0, 1.0, 1.0}
                      .data());
  *hi = FromArray(std::array<double, kN>{2000.0, 2000.0, 2000.0, 20000.0, 20000.0, 200.0, 50.0,
                                         20000.0, 20000.0, 5000.0, 5000.0, 5000.0, 4.0, 5000.0}
                      .data());
}

bool SimulateRunForce(const SpencerParams& p, const FitRun& run, int substeps, double e_max,
                      std::vector<double>* f_hat) {
  f_hat->assign(run.x.size(), 0.0);
  if (run.x.empty()) return true;
  SimResidual sim{&run, substeps, e_max, {}};
  sim.scale.fill(1.0);
  const auto a = ToArray(p);
  const bool ok = sim(a.data(), f_hat->data());
  for (std::size_t k = 0; k < f_hat->size(); ++k) (*f_hat)[k] += run.f[k];
  return ok;
}

FitScore ScoreRun(const SpencerParams& p, const FitRun& run, int substeps, double e_max) {
  std::vector<double> fh;
  FitScore s;
  s.finite = SimulateRunForce(p, run, substeps, e_max, &fh);
  if (!s.finite || run.f.empty()) {
    s.fit_percent = -HUGE_VAL;
    s.rmse_n = HUGE_VAL;
    return s;
  }
  const double mean =
      std::accumulate(run.f.begin(), run.f.end(), 0.0) / static_cast<double>(run.f.size());
  double e2 = 0.0, d2 = 0.0;
  for (std::size_t k = 0; k < fh.size(); ++k) {
    e2 += (run.f[k] - fh[k]) * (run.f[k] - fh[k]);
    d2 += (run.f[k] - mean) * (run.f[k] - mean);
  }
  s.rmse_n = std::sqrt(e2 / static_cast<double>(fh.size()));
  s.fit_percent = d2 > 0.0 ? 100.0 * (1.0 - std::sqrt(e2 / d2)) : -HUGE_VAL;
  return s;
}

SpencerFitResult FitSpencer(const std::vector<FitRun>& runs, const SpencerFitOptions& o) {
  if (runs.empty()) throw std::invalid_argument("no data to fit");
  for (const FitRun& r : runs) {
    if (r.x.size() < 2 || r.v.size() != r.x.size() || r.E.size() != r.x.size() ||
        r.f.size() != r.x.size() || !(r.dt > 0.0)) {
      throw std::invalid_argument(r.name + ": needs at least 2 rows of x, v, E, f");
    }
  }
  if (o.substeps < 1 || o.threads < 1 || o.scatter_starts < 0 || o.polish_starts < 1) {
    throw std::invalid_argument("bad fit options");
  }
  const auto say = [&](const std::string& s) {
    static std::mutex m;
    std::lock_guard<std::mutex> lock(m);
    if (o.progress) o.progress(s);
  };
  // Starts: both presets, then the scatter (log-uniform factor e^[-1, 1] on spencer1997; x0
  // uniform in +-20 cm; n uniform in [1, 3]), clipped to the bounds.
  std::vector<SpencerFitStart> starts;
  starts.push_back({"paper", 0, -1, SpencerParams::Paper()});
  starts.push_back({"spencer1997", 0, -1, SpencerParams::Spencer1997()});
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  SpencerParams lo, hi;
  SpencerFitBounds(&lo, &hi);
  const auto alo = ToArray(lo), ahi = ToArray(hi);
  for (int k = 0; k < o.scatter_starts; ++k) {
    std::array<double, kN> a = ToArray(SpencerParams::Spencer1997());
    for (std::size_t i = 0; i < kN; ++i) a[i] *= std::exp(u(rng));
    a[6] = 20.0 * u(rng);  // x0
    a[12] = 2.0 + u(rng);  // n
    for (std::size_t i = 0; i < kN; ++i) a[i] = std::clamp(a[i], alo[i], ahi[i]);
    starts.push_back({fmt::format("scatter {}", k + 1), 0, -1, FromArray(a.data())});
  }
  std::vector<FitRun> search;
  for (const FitRun& r : runs) search.push_back(Head(r, o.search_s));
  const int n = static_cast<int>(starts.size());
  say(fmt::format("search: {} starts on the first {} s of each run, {} threads", n,
                  o.search_s > 0.0 ? fmt::format("{:g}", o.search_s) : std::string("all"),
                  o.threads));
  ParallelFor(n, o.threads, [&](int i) {
    SpencerFitStart& s = starts[static_cast<std::size_t>(i)];
    int it = 0;
    s.search_cost = Solve(search, o, o.search_iterations, 1, &s.params, &it);
    const FitScore sc = ScoreRun(s.params, search.front(), o.substeps, o.e_max);
    say(std::isfinite(s.search_cost)
            ? fmt::format("  start {}/{} {:<12} {:3d} iterations, search fit {:.1f} %", i + 1, n,
                          s.label, it, sc.fit_percent)
            : fmt::format("  start {}/{} {:<12} diverges at its start: skipped", i + 1, n,
                          s.label));
  });
  std::vector<int> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return starts[static_cast<std::size_t>(a)].search_cost <
           starts[static_cast<std::size_t>(b)].search_cost;
  });
  const int polish = std::min(o.polish_starts, n);
  say(fmt::format("polish: the best {} on all rows", polish));
  // One polish after the other, each Jacobian on all threads.
  ParallelFor(polish, 1, [&](int j) {
    SpencerFitStart& s = starts[static_cast<std::size_t>(order[static_cast<std::size_t>(j)])];
    if (!std::isfinite(s.search_cost)) return;
    int it = 0;
    s.polish_cost = Solve(runs, o, o.polish_iterations, o.threads, &s.params, &it);
    const FitScore sc = ScoreRun(s.params, runs.front(), o.substeps, o.e_max);
    say(fmt::format("  polish {:<12} {:3d} iterations, fit {:.1f} %", s.label, it, sc.fit_percent));
  });
  SpencerFitResult result;
  result.cost = HUGE_VAL;
  for (const SpencerFitStart& s : starts) {
    if (s.polish_cost >= 0.0 && s.polish_cost < result.cost) {
      result.cost = s.polish_cost;
      result.params = s.params;
    }
  }
  if (!std::isfinite(result.cost)) throw std::runtime_error("every start diverged");
  result.starts = std::move(starts);
  return result;
}

std::vector<std::string> SpencerFitWarnings(const SpencerParams& fitted,
                                            const std::vector<FitRun>& runs) {
  std::vector<std::string> out;
  SpencerParams p = fitted, lo, hi;
  SpencerFitBounds(&lo, &hi);
  params::SpencerField fp[params::kSpencerFieldCount], fl[params::kSpencerFieldCount],
      fh[params::kSpencerFieldCount];
  params::SpencerFields(&p, fp);
  params::SpencerFields(&lo, fl);
  params::SpencerFields(&hi, fh);
  for (std::size_t i = 0; i < params::kSpencerFieldCount; ++i) {
    const double v = *fp[i].value, l = *fl[i].value, h = *fh[i].value;
    const double tol = kAtBoundShare * (h - l);
    if (v > l + tol && v < h - tol) continue;
    const bool lower = v <= l + tol;
    out.push_back(fmt::format(
        "warning: {} = {:g} is at its {} bound {:g}: the runs do not pin it inside the physical "
        "box (the best fit lies beyond it); fix it from a datasheet or an earlier fit, or fit "
        "on runs that excite it (a wider stroke, velocity or E range)",
        fp[i].key, v, lower ? "lower" : "upper", lower ? l : h));
  }
  // x0 (the accumulator's rest position) beyond the stroke the runs reached: there
  // k1 (x - x0) is a near-constant force, and k1 and x0 trade off against each other.
  double x_lo = HUGE_VAL, x_hi = -HUGE_VAL;
  for (const FitRun& r : runs) {
    for (const double x : r.x) {
      x_lo = std::min(x_lo, x);
      x_hi = std::max(x_hi, x);
    }
  }
  if (x_lo <= x_hi && (fitted.x0 < x_lo || fitted.x0 > x_hi)) {
    out.push_back(fmt::format(
        "warning: x0 = {:.3g} cm lies beyond the runs' stroke [{:.3g}, {:.3g}] cm: k1 (x - x0) "
        "is then a force offset of about {:.3g} N and k1 = {:.3g} N/cm is not determined by "
        "the runs; read k1 x0 as the accumulator's preload, or fit runs that use the whole "
        "stroke",
        fitted.x0, x_lo, x_hi, -fitted.k1 * fitted.x0, fitted.k1));
  }
  return out;
}

}  // namespace mrd::host
