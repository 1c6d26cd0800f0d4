// Automatic pick of the compact model (sem.hpp): the validation rule, the tolerance rule and the
// cross-validation of the free-run cost inside the identification data.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <thread>

#include "mrd/host/sem.hpp"
#include "sem/estimate/evaluator.hpp"
#include "sem/internal.hpp"
#include "sem/select/one_step_cv.hpp"

namespace mrd::host {
namespace {

using internal::Evaluator;
using internal::FitsWithoutEachFold;
using internal::FoldBound;
using internal::OneStepFoldCosts;
using internal::OneStepResidual;
using internal::Record;

constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<Evaluator::Prepared> PrepareAll(const std::vector<Evaluator>& ev,
                                            const std::vector<SemTerm>& terms) {
  std::vector<Evaluator::Prepared> out;
  for (const Evaluator& e : ev) out.push_back(e.Prepare(terms));
  return out;
}

// Whitening prefilter L(q) = 1 - a_1 q^-1 - ... - a_p q^-p, the inverse of an AR noise model of
// the free-run residual: a = {a_1 ... a_p}; empty: L = 1.
using Prefilter = std::vector<double>;

// Weighted residual z_k = sqrt(w_k) e_k of the rows a, a + 1, ... (sum of z_k^2: the cost).
std::vector<double> Weighted(const Record& r, std::size_t a, const std::vector<double>& e) {
  std::vector<double> z(e.size());
  for (std::size_t k = 0; k < e.size(); ++k) z[k] = std::sqrt(r.w[a + k]) * e[k];
  return z;
}

// Sum of (L(q) z)^2 over a run's weighted residual z; z before the run is 0 (the run is seeded
// with the measured output there).
double FilteredCost(const std::vector<double>& z, const Prefilter& l) {
  double cost = 0.0;
  for (std::size_t k = 0; k < z.size(); ++k) {
    double v = z[k];
    for (std::size_t i = 0; i < l.size() && i < k; ++i) v -= l[i] * z[k - i - 1];
    cost += v * v;
  }
  return cost;
}

// Free-run cost over fold f of every record, prefiltered by l (FreeRun of each, summed).
double FoldRun(const std::vector<Evaluator>& ev, const std::vector<Evaluator::Prepared>& prepared,
               const Eigen::VectorXd& theta, int f, int folds, const Prefilter& l) {
  Evaluator::Scratch scratch;
  std::vector<double> e;
  double cost = 0.0;
  for (std::size_t i = 0; i < ev.size(); ++i) {
    const std::size_t a = FoldBound(ev[i].record(), f, folds);
    e.clear();
    const double c = ev[i].FreeRun(prepared[i], theta, a, FoldBound(ev[i].record(), f + 1, folds),
                                   scratch, l.empty() ? nullptr : &e);
    cost += l.empty() || !std::isfinite(c) ? c : FilteredCost(Weighted(ev[i].record(), a, e), l);
  }
  return cost;
}

std::vector<double> FoldCosts(const std::vector<Evaluator>& ev, const std::vector<SemTerm>& terms,
                              int folds, const Prefilter& l) {
  const auto prepared = PrepareAll(ev, terms);
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
      const std::size_t a = FoldBound(r, f, folds), len = FoldBound(r, f + 1, folds) - a;
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
  const std::vector<Eigen::VectorXd> fits = FitsWithoutEachFold(g, b);
  std::vector<double> out(nf, 0.0);
  for (int f = 0; f < folds; ++f) {
    const auto fi = static_cast<std::size_t>(f);
    const Eigen::VectorXd& theta = fits[fi];
    if (!theta.allFinite()) {
      out[fi] = kInf;
      continue;
    }
    out[fi] = FoldRun(ev, prepared, theta, f, folds, l);
  }
  return out;
}

// Cross-validation of the output-error refined fit: the coefficients refined on all records
// (RefineFreeRun, written back to *coefficients), then per fold one Gauss-Newton step that
// removes the fold's rows from the fit (the refined Jacobian restricted to the other folds),
// and the free run over the fold with those coefficients. Returns per fold costs as FoldCosts,
// and the refined J in *j_refined.
std::vector<double> RefinedFoldCosts(const std::vector<Evaluator>& ev,
                                     const std::vector<SemTerm>& terms, int folds,
                                     const Prefilter& l, std::vector<double>* coefficients,
                                     double* j_refined) {
  const auto nf = static_cast<std::size_t>(folds);
  internal::Jacobian jac;
  Eigen::VectorXd r;
  *j_refined = internal::RefineFreeRun(ev, terms, coefficients, &jac, &r);
  const auto prepared = PrepareAll(ev, terms);
  if (!std::isfinite(*j_refined)) return std::vector<double>(nf, kInf);
  const auto m = static_cast<Eigen::Index>(terms.size());
  Eigen::VectorXd theta(m);
  for (Eigen::Index i = 0; i < m; ++i) theta(i) = (*coefficients)[static_cast<std::size_t>(i)];
  const Eigen::MatrixXd gt = jac.transpose() * jac;
  const Eigen::VectorXd bt = jac.transpose() * r;
  std::vector<double> out(nf, 0.0);
  for (int f = 0; f < folds; ++f) {
    Eigen::MatrixXd g = gt;
    Eigen::VectorXd b = bt;
    Eigen::Index row = 0;  // first row of the record in jac
    for (const Evaluator& e : ev) {
      const Record& rec = e.record();
      const auto a = static_cast<Eigen::Index>(FoldBound(rec, f, folds) - rec.first);
      const auto len =
          static_cast<Eigen::Index>(FoldBound(rec, f + 1, folds) - FoldBound(rec, f, folds));
      const auto rows = jac.middleRows(row + a, len);
      g.noalias() -= rows.transpose() * rows;
      b.noalias() -= rows.transpose() * r.segment(row + a, len);
      row += static_cast<Eigen::Index>(rec.y.size() - rec.first);
    }
    Eigen::VectorXd tf = theta;
    if (m > 0) tf -= g.ldlt().solve(b);
    if (!tf.allFinite()) tf = theta;
    out[static_cast<std::size_t>(f)] = FoldRun(ev, prepared, tf, f, folds, l);
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

// Whitening prefilter of the weighted residuals z (one per record): the least-squares AR fit
// z_k = sum_i a_i z_{k-i} + innovation over every record, its order p in 0 ... kMaxPrefilterOrder
// the one of lowest BIC, n ln(innovation variance) + p ln(n). White residual (output-error
// noise): p = 0, L = 1.
Prefilter FitPrefilter(const std::vector<std::vector<double>>& z) {
  Prefilter best;
  double best_bic = kInf;
  for (int p = 0; p <= kMaxPrefilterOrder; ++p) {
    const auto pp = static_cast<std::size_t>(p);
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(p), x(p);
    double zz = 0.0, n = 0.0;
    for (const auto& r : z) {
      for (std::size_t k = pp; k < r.size(); ++k) {
        for (std::size_t i = 0; i < pp; ++i) x(static_cast<Eigen::Index>(i)) = r[k - i - 1];
        g.noalias() += x * x.transpose();
        b += x * r[k];
        zz += r[k] * r[k];
        n += 1.0;
      }
    }
    if (n < 10.0 * (p + 1)) break;
    const Eigen::VectorXd a = p > 0 ? Eigen::VectorXd(g.ldlt().solve(b)) : Eigen::VectorXd();
    const double s2 = (zz - (p > 0 ? a.dot(b) : 0.0)) / n;
    if (!(s2 > 0.0) || !a.allFinite()) break;
    const double bic = n * std::log(s2) + p * std::log(n);
    if (bic < best_bic) {
      best_bic = bic;
      best.assign(a.data(), a.data() + p);
    }
  }
  return best;
}

// Share of the residuals' power that their own past does not predict: the innovation power
// after the whitening prefilter l over the power, in [0, 1] (1: white, or no power).
double Unpredictable(const std::vector<std::vector<double>>& z, const Prefilter& l) {
  double total = 0.0, innovation = 0.0;
  for (const auto& r : z) {
    total += FilteredCost(r, {});
    innovation += FilteredCost(r, l);
  }
  return total > 0.0 ? std::min(innovation / total, 1.0) : 1.0;
}

double Sum(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return s;
}

}  // namespace

double CrossValidationScore(double cv, std::size_t terms, double candidates, double samples) {
  if (!(cv > 0.0) || !std::isfinite(cv)) return kInf;
  const double n = std::max(samples, 2.0);
  const double c = std::max(candidates, 1.0);
  const double m = static_cast<double>(terms);
  const double k = std::min(m, c);  // an initial term outside the candidates
  const double log_choose = std::lgamma(c + 1.0) - std::lgamma(k + 1.0) - std::lgamma(c - k + 1.0);
  return n * std::log(cv) + m * std::log(n) + 2.0 * log_choose;
}

double internal::SelectionCriterion::Score(const std::vector<double>& costs,
                                           std::size_t terms) const {
  return CrossValidationScore(Sum(costs), terms, candidates, samples);
}

std::vector<double> CrossValidatedCost(const SemSpec& spec, const std::vector<ChannelInfo>& ch,
                                       const std::vector<SemTerm>& terms,
                                       std::span<const DataSet> data, int folds) {
  std::vector<Evaluator> ev;
  for (const DataSet& d : data) ev.emplace_back(spec, ch, d);
  return FoldCosts(ev, terms, folds, {});
}

int SelectByCrossValidation(const std::vector<SemIteration>& its,
                            const std::vector<std::vector<double>>& cv, double samples,
                            double candidates) {
  if (its.empty()) return 0;
  const auto failed = [](const SemIteration& it) { return FailsChecks(it); };
  int pick = -1;
  double best = kInf;
  for (std::size_t i = 0; i < its.size(); ++i) {
    if (failed(its[i])) continue;
    const double score = CrossValidationScore(Sum(cv[i]), its[i].terms.size(), candidates, samples);
    if (!std::isfinite(score)) continue;
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

namespace {

// The rule for records with validation data, a tolerance spec or records too short to fold:
// the fewest terms within the tolerance of the lowest J.
void SelectByTolerance(const SemSpec& spec, bool validation, SemResult* res) {
  res->selected = SelectIteration(res->iterations, spec.selection_tolerance_percent);
  res->selection_rule = fmt::format(
      "fewest terms among the iterations whose {} is within {}% of the lowest{}",
      validation ? "summed validation J" : "identification J", spec.selection_tolerance_percent,
      !validation && spec.selection == Selection::kCrossValidation
          ? fmt::format(" (records too short for {}-fold cross-validation)", kSelectionFolds)
          : "");
}

// An iteration's free-run residual per record: *e the residual (empty where the run diverged),
// *z the weighted one.
void FreeRunResiduals(const std::vector<Evaluator>& ev, const SemIteration& it,
                      std::vector<std::vector<double>>* e, std::vector<std::vector<double>>* z) {
  e->assign(ev.size(), {});
  z->assign(ev.size(), {});
  Eigen::VectorXd theta(static_cast<Eigen::Index>(it.coefficients.size()));
  for (std::size_t i = 0; i < it.coefficients.size(); ++i) {
    theta(static_cast<Eigen::Index>(i)) = it.coefficients[i];
  }
  Evaluator::Scratch scratch;
  for (std::size_t d = 0; d < ev.size(); ++d) {
    const Record& rec = ev[d].record();
    if (!std::isfinite(ev[d].FreeRun(ev[d].Prepare(it.terms), theta, rec.first, rec.y.size(),
                                     scratch, &(*e)[d]))) {
      (*e)[d].clear();
      continue;
    }
    (*z)[d] = Weighted(rec, rec.first, (*e)[d]);
  }
}

// Where the noise enters, and what decided it.
struct NoiseChoice {
  bool one_step = false;                // score the one-step prediction error (else the free run)
  double share_free = 1.0;              // unpredictable share of the free-run residual (auto)
  double share_one_step = 0.0;          // of the one-step residual (auto)
  std::vector<std::vector<double>> r1;  // the lowest-J iteration's one-step residual per record
};

// Where the noise enters (auto): at the output, the free-run residual of a right structure is
// white; in the equation, the one-step residual is, and the noise reaches the free run
// through the model's dynamics, coloured. There the one-step error is the likelihood and the
// free-run error is not (with a nonlinear feedback term the truth's free run is not the best
// free run). A one-step residual mostly predictable from its own past is model mismatch (as
// on noise-free damper data), not noise: the free run, the control-oriented score, is kept.
// z: the lowest-J iteration's weighted free-run residual, l its whitening prefilter.
NoiseChoice ChooseNoise(const SemSpec& spec, const std::vector<Evaluator>& ev,
                        const std::vector<SemTerm>& lowest_terms,
                        const std::vector<std::vector<double>>& z, const Prefilter& l) {
  NoiseChoice n;
  n.one_step = spec.selection_noise == SelectionNoise::kEquation;
  const bool weigh = spec.selection_noise == SelectionNoise::kAuto && !l.empty();
  if (n.one_step || weigh) {
    for (const Evaluator& d : ev) n.r1.push_back(OneStepResidual(d, lowest_terms));
  }
  if (weigh) {
    n.share_free = Unpredictable(z, l);
    n.share_one_step = Unpredictable(n.r1, FitPrefilter(n.r1));
    n.one_step = n.share_one_step >= kEquationNoiseShare && n.share_one_step > n.share_free;
  }
  return n;
}

// Every iteration's per-fold costs, on `threads` workers; with spec.refine, an iteration whose
// refit lowered its J takes the refit's coefficients.
std::vector<std::vector<double>> IterationFoldCosts(const SemSpec& spec,
                                                    const std::vector<Evaluator>& ev,
                                                    const Prefilter& l, bool one_step, int threads,
                                                    std::vector<SemIteration>* its) {
  std::vector<std::vector<double>> cv(its->size());
  const int w = std::max(1, std::min<int>(threads, static_cast<int>(its->size())));
  auto run = [&](int worker) {
    for (std::size_t i = static_cast<std::size_t>(worker); i < its->size();
         i += static_cast<std::size_t>(w)) {
      SemIteration& it = (*its)[i];
      if (one_step) {
        cv[i] = OneStepFoldCosts(ev, it.terms, kSelectionFolds);
      } else if (spec.refine) {  // coefficients already refined: converges at once, gives the
                                 // Jacobian
        double jr = kInf;
        std::vector<double> th = it.coefficients;
        cv[i] = RefinedFoldCosts(ev, it.terms, kSelectionFolds, l, &th, &jr);
        if (jr < it.j) {
          it.j = jr;
          it.coefficients = th;
        }
      } else {
        cv[i] = FoldCosts(ev, it.terms, kSelectionFolds, l);
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < w; ++t) pool.emplace_back(run, t);
  run(0);
  for (auto& t : pool) t.join();
  return cv;
}

// Effective sample size of the scored residual: the one-step residual of the lowest-J
// structure, or the (unfiltered) free-run residual e: the prefiltered one would count coloured
// equation-error noise as independent samples and let spurious terms in.
double ScoredSamples(const std::vector<Evaluator>& ev, const std::vector<std::vector<double>>& e,
                     const NoiseChoice& noise) {
  double n_eff = 0.0;
  for (std::size_t d = 0; d < ev.size(); ++d) {
    const Record& rec = ev[d].record();
    n_eff += noise.one_step ? EffectiveSamples(noise.r1[d])
             : e[d].empty() ? static_cast<double>(rec.y.size() - rec.first)
                            : EffectiveSamples(e[d]);
  }
  return n_eff;
}

// The search's fold costs of a candidate structure, scored as the selection scores.
decltype(internal::SelectionCriterion::fold_costs) SelectionFoldCosts(
    std::shared_ptr<std::vector<Evaluator>> shared_ev, const Prefilter& l, bool refine,
    bool one_step) {
  return [shared_ev, l, refine, one_step](const std::vector<SemTerm>& terms,
                                          std::vector<double>* coefficients, double* j) {
    if (refine && !one_step) {
      return RefinedFoldCosts(*shared_ev, terms, kSelectionFolds, l, coefficients, j);
    }
    if (refine) {
      *j = internal::RefineFreeRun(*shared_ev, terms, coefficients);
    } else {
      Eigen::VectorXd theta(static_cast<Eigen::Index>(coefficients->size()));
      for (std::size_t i = 0; i < coefficients->size(); ++i) {
        theta(static_cast<Eigen::Index>(i)) = (*coefficients)[i];
      }
      *j = FoldRun(*shared_ev, PrepareAll(*shared_ev, terms), theta, 0, 1, {});
    }
    return one_step ? OneStepFoldCosts(*shared_ev, terms, kSelectionFolds)
                    : FoldCosts(*shared_ev, terms, kSelectionFolds, l);
  };
}

// The cross-validation rule in words (res->selection_rule).
std::string CrossValidationRule(const SemSpec& spec, const NoiseChoice& noise, const Prefilter& l,
                                std::size_t num_candidates, double n_eff) {
  std::string filter = "1";
  for (std::size_t i = 0; i < l.size(); ++i) {
    filter += fmt::format(" {} {:.3g} q^-{}", l[i] < 0.0 ? "+" : "-", std::fabs(l[i]), i + 1);
  }
  if (noise.one_step) {
    return fmt::format(
        "{}-fold cross-validation of the one-step prediction error inside the identification "
        "data (noise in the equation: {}): the iteration of lowest N ln(CV J) + m ln(N) + 2 ln(C "
        "choose m) (extended BIC, m terms of C = {} candidates), N = {:.0f} effective samples of "
        "the lowest-J iteration's one-step residual; each fold's coefficients are the least "
        "squares on the other folds",
        kSelectionFolds,
        spec.selection_noise == SelectionNoise::kEquation
            ? "selection_noise = \"equation\""
            : fmt::format("of the lowest-J iteration's residuals, {:.0f} % of the one-step one "
                          "is unpredictable from its own past, {:.0f} % of the free-run one, "
                          "L(q) = {}",
                          100.0 * noise.share_one_step, 100.0 * noise.share_free, filter),
        num_candidates, n_eff);
  }
  std::string rule = fmt::format(
      "{}-fold cross-validation of the {} free-run J inside the identification data: the "
      "iteration of lowest N ln(CV J) + m ln(N) + 2 ln(C choose m) (extended BIC, m terms of C = "
      "{} candidates), N = {:.0f} effective samples of the lowest-J iteration's free-run residual; "
      "residuals prefiltered by L(q) = {}, the AR({}) whitening filter of that residual (order by "
      "BIC, at most {})",
      kSelectionFolds, spec.refine ? "output-error refined" : "least-squares", num_candidates,
      n_eff, filter, l.size(), kMaxPrefilterOrder);
  if (spec.selection_noise == SelectionNoise::kAuto && !l.empty()) {
    rule += fmt::format(
        " (free run scored: {:.0f} % of the one-step residual's power is unpredictable from its "
        "own past, {:.0f} % of the free-run residual's; the one-step score needs at least {:.0f} "
        "% and more than the free run's: model mismatch, not noise in the equation)",
        100.0 * noise.share_one_step, 100.0 * noise.share_free, 100.0 * kEquationNoiseShare);
  }
  return rule;
}

}  // namespace

void internal::SelectModel(const SemSpec& spec, std::span<const DataSet> identification,
                           int threads, SemResult* res, SelectionCriterion* criterion) {
  if (criterion != nullptr) *criterion = {};
  auto& its = res->iterations;
  const bool validation = !its.empty() && !its.front().validation_j.empty();
  std::size_t shortest = std::numeric_limits<std::size_t>::max();
  for (const DataSet& d : identification) {
    shortest = std::min(shortest, d.rows() - static_cast<std::size_t>(spec.MaxDelay()));
  }
  const bool cv_possible = !identification.empty() &&
                           shortest >= kMinFoldSamples * static_cast<std::size_t>(kSelectionFolds);
  if (validation || spec.selection == Selection::kTolerance || !cv_possible) {
    SelectByTolerance(spec, validation, res);
    return;
  }
  auto shared_ev = std::make_shared<std::vector<Evaluator>>();  // outlives the call (criterion)
  std::vector<Evaluator>& ev = *shared_ev;
  for (const DataSet& d : identification) ev.emplace_back(spec, res->channels, d);
  // The lowest-J iteration's free-run residual: the noise's colour (prefilter) and the
  // effective sample size.
  std::size_t low = 0;
  for (std::size_t i = 1; i < its.size(); ++i) {
    if (its[i].j < its[low].j) low = i;
  }
  std::vector<std::vector<double>> e, z;
  FreeRunResiduals(ev, its[low], &e, &z);
  const Prefilter l = FitPrefilter(z);
  const NoiseChoice noise = ChooseNoise(spec, ev, its[low].terms, z, l);
  const std::vector<std::vector<double>> cv =
      IterationFoldCosts(spec, ev, l, noise.one_step, threads, &its);
  for (std::size_t i = 0; i < its.size(); ++i) its[i].cv_j = cv[i];
  const double n_eff = ScoredSamples(ev, e, noise);
  res->cv_one_step = noise.one_step;
  res->selected = SelectByCrossValidation(its, cv, n_eff, static_cast<double>(res->num_candidates));
  if (criterion != nullptr) {
    criterion->samples = n_eff;
    criterion->candidates = static_cast<double>(res->num_candidates);
    criterion->fold_costs = SelectionFoldCosts(shared_ev, l, spec.refine, noise.one_step);
  }
  res->selection_rule = CrossValidationRule(spec, noise, l, res->num_candidates, n_eff);
}

}  // namespace mrd::host
