// Automatic pick of the compact model (sem.hpp): the validation rule, the tolerance rule and the
// cross-validation of the free-run cost inside the identification data.
#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "mrd/host/sem.hpp"
#include "sem_internal.hpp"

namespace mrd::host {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double Pow(double b, int p) {
  double v = 1.0;
  for (int i = 0; i < p; ++i) v *= b;
  return v;
}

// One identification record prepared for cross-validation (normalised signals).
struct Record {
  std::vector<double> y;                   // measured output, every row
  std::vector<std::vector<double>> input;  // per regressor: transformed input (empty: output)
  std::vector<double> w;                   // cost weight per row, divided by the scored count
  std::size_t first = 0;                   // first scored row (spec.MaxDelay())
};

class Evaluator {
 public:
  Evaluator(const SemSpec& spec, const std::vector<ChannelInfo>& ch, const DataSet& d)
      : spec_(spec) {
    const auto signals = spec.Signals();
    const auto& y = d.Column(spec.output);
    rec_.y.resize(y.size());
    for (std::size_t k = 0; k < y.size(); ++k) rec_.y[k] = y[k] / ch[0].scale;
    rec_.input.resize(spec.regressors.size());
    for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
      const auto& reg = spec.regressors[r];
      if (reg.signal == spec.output) continue;
      const std::size_t ci = static_cast<std::size_t>(
          std::find(signals.begin(), signals.end(), reg.signal) - signals.begin());
      rec_.input[r] = internal::TransformSignal(reg, d.Column(reg.signal), ch[ci].scale);
    }
    rec_.first = static_cast<std::size_t>(spec.MaxDelay());
    const double nd = static_cast<double>(y.size() - rec_.first);
    rec_.w.resize(y.size());
    for (std::size_t k = 0; k < y.size(); ++k) {
      const double w = spec.weighting == CostWeighting::kRelative
                           ? 1.0 / std::max(std::fabs(rec_.y[k]), spec.floor)
                           : 1.0;
      rec_.w[k] = w / nd;
    }
  }

  const Record& record() const { return rec_; }

  // Value of a term at row k with the output history ys (measured or simulated).
  double Term(const SemTerm& t, const std::vector<double>& ys, std::size_t k) const {
    double v = 1.0;
    for (const auto& f : t.factors) {
      const auto& reg = spec_.regressors[static_cast<std::size_t>(f.regressor)];
      const std::size_t kk = k - static_cast<std::size_t>(f.delay);
      const auto& in = rec_.input[static_cast<std::size_t>(f.regressor)];
      const double x = in.empty() ? ApplyTransform(reg.transform, reg.exponent, ys[kk]) : in[kk];
      v *= Pow(x, f.power);
    }
    return v;
  }

  // Weighted squared free-run error over rows [a, b), seeded by the measured output before a;
  // +inf when the run leaves |y| <= divergence_limit or is not finite.
  double FreeRun(const std::vector<SemTerm>& terms, const Eigen::VectorXd& theta, std::size_t a,
                 std::size_t b, std::vector<double>* residual = nullptr) const {
    std::vector<double> ys(rec_.y.begin(), rec_.y.begin() + static_cast<std::ptrdiff_t>(b));
    double cost = 0.0;
    for (std::size_t k = a; k < b; ++k) {
      double v = 0.0;
      for (std::size_t i = 0; i < terms.size(); ++i) {
        v += theta(static_cast<Eigen::Index>(i)) * Term(terms[i], ys, k);
      }
      if (!(std::fabs(v) <= spec_.divergence_limit)) return kInf;
      ys[k] = v;
      const double e = rec_.y[k] - v;
      cost += rec_.w[k] * e * e;
      if (residual != nullptr) residual->push_back(e);
    }
    return std::isfinite(cost) ? cost : kInf;
  }

 private:
  const SemSpec& spec_;
  Record rec_;
};

// Fold boundaries of a record's scored rows: part f is [Bound(f), Bound(f + 1)).
std::size_t Bound(const Record& r, int f, int folds) {
  const std::size_t n = r.y.size() - r.first;
  return r.first + n * static_cast<std::size_t>(f) / static_cast<std::size_t>(folds);
}

std::vector<double> FoldCosts(const std::vector<Evaluator>& ev,
                              const std::vector<SemTerm>& terms, int folds) {
  const auto m = static_cast<Eigen::Index>(terms.size());
  const auto nf = static_cast<std::size_t>(folds);
  // Per fold: Gram matrix and right-hand side of the one-step regression on its rows.
  std::vector<Eigen::MatrixXd> g(nf, Eigen::MatrixXd::Zero(m, m));
  std::vector<Eigen::VectorXd> b(nf, Eigen::VectorXd::Zero(m));
  for (const Evaluator& e : ev) {
    if (m == 0) break;
    const Record& r = e.record();
    for (int f = 0; f < folds; ++f) {
      const auto fi = static_cast<std::size_t>(f);
      const std::size_t a = Bound(r, f, folds), len = Bound(r, f + 1, folds) - a;
      Eigen::MatrixXd phi(static_cast<Eigen::Index>(len), m);
      for (Eigen::Index i = 0; i < m; ++i) {
        for (std::size_t k = 0; k < len; ++k) {
          phi(static_cast<Eigen::Index>(k), i) =
              e.Term(terms[static_cast<std::size_t>(i)], r.y, a + k);
        }
      }
      const Eigen::Map<const Eigen::VectorXd> y(r.y.data() + a, static_cast<Eigen::Index>(len));
      g[fi].noalias() += phi.transpose() * phi;
      b[fi].noalias() += phi.transpose() * y;
    }
  }
  Eigen::MatrixXd gt = Eigen::MatrixXd::Zero(m, m);
  Eigen::VectorXd bt = Eigen::VectorXd::Zero(m);
  for (std::size_t f = 0; f < nf; ++f) {
    gt += g[f];
    bt += b[f];
  }
  std::vector<double> out(nf, 0.0);
  for (int f = 0; f < folds; ++f) {
    const auto fi = static_cast<std::size_t>(f);
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(m);
    if (m > 0) {
      const Eigen::MatrixXd gf = gt - g[fi];
      Eigen::LLT<Eigen::MatrixXd> llt(gf);
      theta = llt.info() == Eigen::Success ? Eigen::VectorXd(llt.solve(bt - b[fi]))
                                            : Eigen::VectorXd(gf.completeOrthogonalDecomposition()
                                                                  .solve(bt - b[fi]));
    }
    if (!theta.allFinite()) {
      out[fi] = kInf;
      continue;
    }
    for (const Evaluator& e : ev) {
      out[fi] += e.FreeRun(terms, theta, Bound(e.record(), f, folds),
                           Bound(e.record(), f + 1, folds));
    }
  }
  return out;
}

// Effective number of independent samples of a residual sequence for a cost that sums its
// squares: n / (1 + 2 sum_l rho_l^2) (for Gaussian e, var(sum e^2) = 2 sigma^4 sum_ij rho_ij^2),
// over lags 1 ... n/4 whose autocorrelation |rho_l| exceeds 2/sqrt(n) (the others are taken as
// estimation noise); in [1, n].
double EffectiveSamples(const std::vector<double>& e) {
  const std::size_t n = e.size();
  if (n < 4) return static_cast<double>(n);
  double mean = 0.0;
  for (double v : e) mean += v;
  mean /= static_cast<double>(n);
  double c0 = 0.0;
  for (double v : e) c0 += (v - mean) * (v - mean);
  if (!(c0 > 0.0)) return static_cast<double>(n);
  const double noise = 2.0 / std::sqrt(static_cast<double>(n));
  double tau = 1.0;
  for (std::size_t lag = 1; lag <= n / 4; ++lag) {
    double c = 0.0;
    for (std::size_t k = lag; k < n; ++k) c += (e[k] - mean) * (e[k - lag] - mean);
    const double rho = c / c0;
    if (std::fabs(rho) > noise) tau += 2.0 * rho * rho;
  }
  return std::clamp(static_cast<double>(n) / tau, 1.0, static_cast<double>(n));
}

double Sum(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return s;
}

}  // namespace

std::vector<double> CrossValidatedCost(const SemSpec& spec, const std::vector<ChannelInfo>& ch,
                                       const std::vector<SemTerm>& terms,
                                       std::span<const DataSet> data, int folds) {
  std::vector<Evaluator> ev;
  for (const DataSet& d : data) ev.emplace_back(spec, ch, d);
  return FoldCosts(ev, terms, folds);
}

int SelectByCrossValidation(const std::vector<SemIteration>& its,
                            const std::vector<std::vector<double>>& cv, double samples) {
  if (its.empty()) return 0;
  const double n = std::max(samples, 2.0);
  const auto failed = [](const SemIteration& it) { return it.stress.checked && !it.stress.pass; };
  int pick = -1;
  double best = kInf;
  for (std::size_t i = 0; i < its.size(); ++i) {
    if (failed(its[i])) continue;
    const double total = Sum(cv[i]);
    if (!(total > 0.0) || !std::isfinite(total)) continue;
    const double score =
        n * std::log(total) + static_cast<double>(its[i].terms.size()) * std::log(n);
    if (pick < 0 || score < best) {
      pick = static_cast<int>(i);
      best = score;
    }
  }
  if (pick >= 0) return its[static_cast<std::size_t>(pick)].iteration;
  for (auto it = its.rbegin(); it != its.rend(); ++it) {
    if (!failed(*it)) return it->iteration;  // every passing cross-validation diverged
  }
  return -1;
}

void internal::SelectModel(const SemSpec& spec, std::span<const DataSet> identification,
                           int threads, SemResult* res) {
  auto& its = res->iterations;
  const bool validation = !its.empty() && !its.front().validation_j.empty();
  std::size_t shortest = std::numeric_limits<std::size_t>::max();
  for (const DataSet& d : identification) {
    shortest = std::min(shortest, d.rows() - static_cast<std::size_t>(spec.MaxDelay()));
  }
  const bool cv_possible =
      !identification.empty() &&
      shortest >= kMinFoldSamples * static_cast<std::size_t>(kSelectionFolds);
  if (validation || spec.selection == Selection::kTolerance || !cv_possible) {
    res->selected = SelectIteration(its, spec.selection_tolerance_percent);
    res->selection_rule = fmt::format(
        "fewest terms among the iterations whose {} is within {}% of the lowest{}",
        validation ? "summed validation J" : "identification J", spec.selection_tolerance_percent,
        !validation && spec.selection == Selection::kCrossValidation
            ? fmt::format(" (records too short for {}-fold cross-validation)", kSelectionFolds)
            : "");
    return;
  }
  std::vector<Evaluator> ev;
  for (const DataSet& d : identification) ev.emplace_back(spec, res->channels, d);
  std::vector<std::vector<double>> cv(its.size());
  const int w = std::max(1, std::min<int>(threads, static_cast<int>(its.size())));
  auto run = [&](int worker) {
    for (std::size_t i = static_cast<std::size_t>(worker); i < its.size();
         i += static_cast<std::size_t>(w)) {
      cv[i] = FoldCosts(ev, its[i].terms, kSelectionFolds);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < w; ++t) pool.emplace_back(run, t);
  run(0);
  for (auto& t : pool) t.join();
  for (std::size_t i = 0; i < its.size(); ++i) its[i].cv_j = cv[i];
  // Effective sample size from the free-run residual of the lowest-J iteration.
  std::size_t low = 0;
  for (std::size_t i = 1; i < its.size(); ++i) {
    if (its[i].j < its[low].j) low = i;
  }
  double n_eff = 0.0;
  Eigen::VectorXd theta(static_cast<Eigen::Index>(its[low].coefficients.size()));
  for (std::size_t i = 0; i < its[low].coefficients.size(); ++i) {
    theta(static_cast<Eigen::Index>(i)) = its[low].coefficients[i];
  }
  for (const Evaluator& e : ev) {
    std::vector<double> residual;
    if (std::isfinite(e.FreeRun(its[low].terms, theta, e.record().first, e.record().y.size(),
                                &residual))) {
      n_eff += EffectiveSamples(residual);
    } else {
      n_eff += static_cast<double>(e.record().y.size() - e.record().first);
    }
  }
  res->selected = SelectByCrossValidation(its, cv, n_eff);
  res->selection_rule = fmt::format(
      "{}-fold cross-validation of the free-run J inside the identification data: the iteration "
      "of lowest N ln(CV J) + terms ln(N), N = {:.0f} effective samples of the lowest-J "
      "iteration's free-run residual",
      kSelectionFolds, n_eff);
}

}  // namespace mrd::host
