#include "mrd/host/sem.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <limits>
#include <map>
#include <thread>
#include <unordered_map>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "mrd/host/input_error.hpp"
#include "mrd/host/sem_stress.hpp"
#include "sem_evaluator.hpp"
#include "sem_internal.hpp"
#include "sem_kernels.hpp"

namespace mrd::host {

std::vector<double> internal::TransformSignal(const ElementaryRegressor& reg,
                                              const std::vector<double>& raw, double scale) {
  std::vector<double> out(raw.size());
  if (reg.transform == Transform::kLowPass) {
    const double a = LowPassPole(reg.exponent);
    double r = 0.0;
    for (std::size_t k = 0; k < raw.size(); ++k) out[k] = r = LowPassStep(a, r, raw[k] / scale);
    return out;
  }
  for (std::size_t k = 0; k < raw.size(); ++k) {
    out[k] = ApplyTransform(reg.transform, reg.exponent, raw[k] / scale);
  }
  return out;
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kBlock = 256;      // samples per block of the free-run pass
constexpr std::size_t kChunk = 64;       // candidates per work item (one column sweep)
constexpr int kMaxExchanges = 8;         // exchange passes per major iteration
constexpr std::size_t kExchangePool = 64;  // candidates (best one-step rank) tried per term
constexpr double kExchangeGain = 1e-9;   // relative J decrease an exchange must bring
constexpr double kCollinear = 1e-13;     // relative Schur complement below which a
                                         // candidate is taken as linearly dependent

// Runs fn(item, worker) for item in [0, n) on `threads` workers (dynamic schedule).
template <typename F>
void ParallelFor(std::size_t n, int threads, F&& fn) {
  const int w = std::max(1, std::min<int>(threads, static_cast<int>(n)));
  if (w <= 1) {
    for (std::size_t i = 0; i < n; ++i) fn(i, 0);
    return;
  }
  std::atomic<std::size_t> next{0};
  auto run = [&](int worker) {
    for (std::size_t i = next++; i < n; i = next++) fn(i, worker);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < w; ++t) pool.emplace_back(run, t);
  run(0);
  for (auto& t : pool) t.join();
}

// Lowers an atomic double to v if v is smaller.
void AtomicMin(std::atomic<double>& a, double v) {
  double cur = a.load();
  while (v < cur && !a.compare_exchange_weak(cur, v)) {
  }
}

double Pow(double b, int p) {
  double v = 1.0;
  for (int i = 0; i < p; ++i) v *= b;
  return v;
}

struct Segment {
  std::size_t start = 0;  // stacked index of the first scored sample
  std::size_t len = 0;
  std::vector<double> seed;  // measured normalised output before start, oldest first
};

struct OutFactor {
  Transform transform;
  double exponent;
  int delay;
  int power;
};

struct Cand {
  SemTerm term;
  std::vector<int> in_cols;   // elementary power columns of the input factors
  std::vector<int> out_cols;  // ... of the output factors (measured output, one-step)
  std::vector<OutFactor> out; // output factors, for the general free run
  int ypow = 0;               // fast path: power of y(k-1)
  double ss = 0.0;            // phi' phi
  double sy = 0.0;            // phi' y
};

// Everything the search needs about the identification data.
class Engine {
 public:
  Engine(const SemSpec& spec, std::span<const DataSet> data, const std::vector<ChannelInfo>& ch,
         int threads)
      : spec_(spec), threads_(std::max(1, threads)) {
    const int dmax = spec.MaxDelay();
    const auto signals = spec.Signals();
    fast_ = true;
    for (const auto& r : spec.regressors) {
      if (r.signal == spec.output &&
          (r.transform != Transform::kIdentity || r.delays != std::vector<int>{1})) {
        fast_ = false;
      }
    }
    // Stacked scored samples.
    std::vector<std::vector<const std::vector<double>*>> raw(data.size());
    for (std::size_t d = 0; d < data.size(); ++d) {
      Segment seg;
      seg.start = n_;
      seg.len = data[d].rows() - static_cast<std::size_t>(dmax);
      const auto& y = data[d].Column(spec.output);
      for (int k = 0; k < dmax; ++k) seg.seed.push_back(y[k] / ch[0].scale);
      const double nd = static_cast<double>(seg.len);
      for (std::size_t k = static_cast<std::size_t>(dmax); k < data[d].rows(); ++k) {
        const double yn = y[k] / ch[0].scale;
        y_.push_back(yn);
        const double w = spec.weighting == CostWeighting::kRelative
                             ? 1.0 / std::max(std::fabs(yn), spec.floor)
                             : 1.0;
        wn_.push_back(w / nd);
      }
      n_ += seg.len;
      segs_.push_back(std::move(seg));
    }
    ones_.assign(n_, 1.0);
    // Elementary power columns.
    col_index_.assign(spec.regressors.size(), {});
    base_index_.assign(spec.regressors.size(), {});
    for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
      const auto& reg = spec.regressors[r];
      const std::size_t ci = static_cast<std::size_t>(
          std::find(signals.begin(), signals.end(), reg.signal) - signals.begin());
      col_index_[r].assign(kMaxDelay + 1, std::vector<int>(kMaxPower + 1, -1));
      base_index_[r].assign(kMaxDelay + 1, -1);
      std::vector<std::vector<double>> transformed(data.size());
      for (std::size_t d = 0; d < data.size(); ++d) {
        transformed[d] = internal::TransformSignal(reg, data[d].Column(reg.signal), ch[ci].scale);
      }
      for (int delay : reg.delays) {
        std::vector<double> base;
        base.reserve(n_);
        for (std::size_t d = 0; d < data.size(); ++d) {
          const auto& s = transformed[d];
          for (std::size_t k = static_cast<std::size_t>(dmax); k < data[d].rows(); ++k) {
            base.push_back(s[k - static_cast<std::size_t>(delay)]);
          }
        }
        base_index_[r][delay] = static_cast<int>(base_.size());
        base_.push_back(base);
        for (int p : reg.powers) {
          std::vector<double> col(n_);
          for (std::size_t g = 0; g < n_; ++g) col[g] = Pow(base[g], p);
          col_index_[r][delay][p] = static_cast<int>(cols_.size());
          cols_.push_back(std::move(col));
        }
      }
    }
  }

  // Registers a candidate term; returns its index.
  int AddCandidate(const SemTerm& t) {
    Cand c;
    c.term = t;
    for (const auto& f : t.factors) {
      const auto& reg = spec_.regressors[f.regressor];
      if (f.power < 1 || f.power > static_cast<int>(kMaxPower) || f.delay < 0 ||
          f.delay > static_cast<int>(kMaxDelay)) {
        throw InputError("", 0, fmt::format("bad term '{}': power {} or delay {} out of range",
                                            TermName(spec_, t), f.power, f.delay));
      }
      int col = col_index_[f.regressor][f.delay][f.power];
      if (col < 0) {  // power not offered (merged initial term): add the column
        const auto& b = base_[base_index_[f.regressor][f.delay]];
        std::vector<double> v(n_);
        for (std::size_t g = 0; g < n_; ++g) v[g] = Pow(b[g], f.power);
        col = static_cast<int>(cols_.size());
        col_index_[f.regressor][f.delay][f.power] = col;
        cols_.push_back(std::move(v));
      }
      if (reg.signal == spec_.output) {
        c.out_cols.push_back(col);
        c.out.push_back({reg.transform, reg.exponent, f.delay, f.power});
        c.ypow += f.power;
      } else {
        c.in_cols.push_back(col);
      }
    }
    std::vector<const double*> ptr;  // columns never move once made
    for (int col : c.in_cols) ptr.push_back(cols_[col].data());
    for (int col : c.out_cols) ptr.push_back(cols_[col].data());
    factor_cols_.push_back(std::move(ptr));
    cands_.push_back(std::move(c));
    return static_cast<int>(cands_.size()) - 1;
  }

  // phi' phi and phi' y of every candidate.
  // phi'phi and phi'y of every candidate (sums in sample order).
  void PrepareCandidates() {
    std::vector<double> ss(cands_.size()), sy(cands_.size());
    GramSums(nullptr, ss.data());
    GramSums(y_.data(), sy.data());
    for (std::size_t c = 0; c < cands_.size(); ++c) {
      cands_[c].ss = ss[c];
      cands_[c].sy = sy[c];
    }
  }

  std::size_t num_candidates() const { return cands_.size(); }
  const Cand& cand(int c) const { return cands_[c]; }
  bool fast() const { return fast_; }
  double divergence_limit() const { return spec_.divergence_limit; }

  // Cross products phi_t' phi_c for every candidate c (cached; sums in sample order,
  // kMaxLanes candidates at a time).
  const std::vector<double>& Cross(int t) {
    auto it = cross_.find(t);
    if (it != cross_.end()) return it->second;
    std::vector<double> phit(n_);
    for (std::size_t g0 = 0; g0 < n_; g0 += kBlock) {
      Phi(t, g0, std::min(kBlock, n_ - g0), phit.data() + g0);
    }
    std::vector<double> out(cands_.size());
    GramSums(phit.data(), out.data());
    return cross_.emplace(t, std::move(out)).first->second;
  }

  // Input part of a candidate, whole stacked length (cached).
  const std::vector<double>& U(int t) {
    auto it = u_.find(t);
    if (it != u_.end()) return it->second;
    std::vector<double> u(n_);
    for (std::size_t g0 = 0; g0 < n_; g0 += kBlock) {
      Input(t, g0, std::min(kBlock, n_ - g0), u.data() + g0);
    }
    return u_.emplace(t, std::move(u)).first->second;
  }

  // LS on the one-step regression for a set of terms; false when singular.
  bool Solve(const std::vector<int>& terms, std::vector<double>* theta) {
    const std::size_t m = terms.size();
    theta->assign(m, 0.0);
    if (m == 0) return true;
    Eigen::MatrixXd g(m, m);
    Eigen::VectorXd b(m);
    for (std::size_t i = 0; i < m; ++i) {
      const auto& ci = Cross(terms[i]);
      for (std::size_t j = 0; j < m; ++j) g(i, j) = ci[terms[j]];
      b(i) = cands_[terms[i]].sy;
    }
    Eigen::LLT<Eigen::MatrixXd> llt(g);
    Eigen::VectorXd x;
    if (llt.info() == Eigen::Success) {
      x = llt.solve(b);
    } else {
      x = g.completeOrthogonalDecomposition().solve(b);
    }
    for (std::size_t i = 0; i < m; ++i) {
      if (!std::isfinite(x(i))) return false;
      (*theta)[i] = x(i);
    }
    return true;
  }

  // One simulation job: model terms (shared) with own coefficients, plus an optional extra
  // candidate computed on the fly.
  struct Job {
    std::vector<double> theta;  // per shared term
    int extra = -1;
    double theta_extra = 0.0;
    double cost = 0.0;
    bool dead = false;  // diverged or exceeded the bound
    bool diverged = false;
  };

  // Free-run costs of jobs over the shared terms. A job stops (dead) once its partial cost
  // exceeds bound (costs above the bound are then lower bounds only).
  void Simulate(const std::vector<int>& terms, std::span<Job> jobs, const std::atomic<double>& bound,
                std::vector<double>& scratch) {
    if (fast_) {
      SimulateFast(terms, jobs, bound, scratch);
    } else {
      SimulateGeneral(terms, jobs, bound, scratch);
    }
  }

  std::size_t n() const { return n_; }
  double YtWy() const {
    double s = 0.0;
    for (std::size_t g = 0; g < n_; ++g) s += wn_[g] * y_[g] * y_[g];
    return s;
  }

 private:
  // out[c] = sum_k phi_c(k) x(k) for every candidate c (x == nullptr: phi_c(k)^2), summed in
  // sample order, kMaxLanes candidates at a time (sem_kernels.hpp).
  void GramSums(const double* x, double* out) {
    const std::size_t items = (cands_.size() + kGramItem - 1) / kGramItem;
    ParallelFor(items, threads_, [&](std::size_t item, int) { GramItem(item, x, out); });
  }

  // GramSums of the candidates [item * kGramItem, ...): one sweep over the samples for all of
  // them (a block's columns stay in cache).
  static constexpr std::size_t kGramItem = 8 * internal::kMaxLanes;
  void GramItem(std::size_t item, const double* x, double* out) const {
    using internal::kLaneWidth, internal::kMaxLanes;
    const std::size_t c_begin = item * kGramItem;
    const std::size_t c_end = std::min(cands_.size(), c_begin + kGramItem);
    // Per group of kMaxLanes: factor columns [lane * nf + k], padded with ones.
    std::vector<std::vector<const double*>> f;
    std::vector<std::size_t> nf;
    for (std::size_t c0 = c_begin; c0 < c_end; c0 += kMaxLanes) {
      const std::size_t nc = std::min(kMaxLanes, c_end - c0);
      const std::size_t lanes = (nc + kLaneWidth - 1) / kLaneWidth * kLaneWidth;
      std::size_t n = 1;
      for (std::size_t l = 0; l < nc; ++l) n = std::max(n, factor_cols_[c0 + l].size());
      std::vector<const double*> fg(lanes * n, ones_.data());
      for (std::size_t l = 0; l < nc; ++l) {
        std::copy(factor_cols_[c0 + l].begin(), factor_cols_[c0 + l].end(),
                  fg.begin() + static_cast<std::ptrdiff_t>(l * n));
      }
      f.push_back(std::move(fg));
      nf.push_back(n);
    }
    std::vector<double> acc(f.size() * kMaxLanes, 0.0);
    for (std::size_t g0 = 0; g0 < n_; g0 += kBlock) {
      const std::size_t len = std::min(kBlock, n_ - g0);
      for (std::size_t g = 0; g < f.size(); ++g) {
        const int nv = static_cast<int>(f[g].size() / nf[g] / kLaneWidth);
        internal::LaneGram(nv, f[g].data(), nf[g], g0, x, len, &acc[g * kMaxLanes]);
      }
    }
    std::copy(acc.begin(), acc.begin() + static_cast<std::ptrdiff_t>(c_end - c_begin),
              out + c_begin);
  }

  // Input part of candidate c (product of its input factors; 1 without) over [g0, g0 + len).
  void Input(int c, std::size_t g0, std::size_t len, double* out) const {
    internal::Product(factor_cols_[c].data(), cands_[c].in_cols.size(), g0, len, out);
  }

  // Regressor of candidate c (input then output factors, measured output).
  void Phi(int c, std::size_t g0, std::size_t len, double* out) const {
    internal::Product(factor_cols_[c].data(), factor_cols_[c].size(), g0, len, out);
  }

  int ExtraPow(const Job& j) const { return j.extra >= 0 ? cands_[j.extra].ypow : -1; }

  // Free run of the fast path (y(k-1) only): y(k) = sum_q c_q(k) y(k-1)^q with
  // c_q(k) = sum over terms of y-power q of theta_i u_i(k) (+ the job's extra candidate).
  // Jobs go through in lane groups of up to kMaxLanes (sem_kernels.hpp gives the cost model);
  // the bound is checked every kBlock samples, as are divergence and finiteness.
  void SimulateFast(const std::vector<int>& terms, std::span<Job> jobs,
                    const std::atomic<double>& bound, std::vector<double>& scratch) {
    using internal::kLaneWidth, internal::kMaxLanes, internal::kSubBlock;
    int q_max = 0;
    for (int t : terms) q_max = std::max(q_max, cands_[t].ypow);
    for (const Job& j : jobs) {
      if (j.extra >= 0) q_max = std::max(q_max, cands_[j.extra].ypow);
    }
    const std::size_t nq = static_cast<std::size_t>(q_max) + 1;
    std::vector<std::vector<std::size_t>> by_q(nq);  // term indices of each y power
    std::vector<std::vector<const double*>> u_q(nq);
    for (std::size_t i = 0; i < terms.size(); ++i) {
      const auto q = static_cast<std::size_t>(cands_[terms[i]].ypow);
      by_q[q].push_back(i);
      u_q[q].push_back(U(terms[i]).data());
    }
    std::vector<char> no_terms(nq);
    for (std::size_t q = 0; q < nq; ++q) no_terms[q] = by_q[q].empty();
    // Lane sums c[q][s][lane], thetas theta[term][lane] (by_q order), one input block.
    const std::size_t c_size = nq * kSubBlock * kMaxLanes;
    scratch.assign(c_size + terms.size() * kMaxLanes, 0.0);
    double* c = scratch.data();
    double* theta = c + c_size;
    std::vector<const double*> ex_f;  // [lane * nf + k]: the extra's input factor columns
    double ex_th[kMaxLanes];
    int ex_q[kMaxLanes];
    std::vector<double> yprev(jobs.size());
    std::vector<std::size_t> alive;
    const double lim = spec_.divergence_limit;
    for (const Segment& seg : segs_) {
      for (std::size_t j = 0; j < jobs.size(); ++j) yprev[j] = seg.seed.back();
      for (std::size_t g0 = seg.start; g0 < seg.start + seg.len; g0 += kBlock) {
        const std::size_t len = std::min(kBlock, seg.start + seg.len - g0);
        const double bnd = bound.load(std::memory_order_relaxed);
        // Live jobs by the extra's y power (a lane vector then mostly adds to one c_q).
        alive.clear();
        for (int q = -1; q <= q_max; ++q) {
          for (std::size_t j = 0; j < jobs.size(); ++j) {
            if (!jobs[j].dead && ExtraPow(jobs[j]) == q) alive.push_back(j);
          }
        }
        for (std::size_t a0 = 0; a0 < alive.size(); a0 += kMaxLanes) {
          const std::size_t na = std::min(kMaxLanes, alive.size() - a0);
          const std::size_t nv = (na + kLaneWidth - 1) / kLaneWidth;
          const std::size_t lanes = nv * kLaneWidth;  // unused lanes: theta 0, output 0
          double p[kMaxLanes] = {}, acc[kMaxLanes] = {};
          bool bad[kMaxLanes] = {};
          std::size_t col = 0;
          for (std::size_t q = 0; q < nq; ++q) {
            for (std::size_t i : by_q[q]) {
              for (std::size_t l = 0; l < lanes; ++l) {
                theta[col * lanes + l] = l < na ? jobs[alive[a0 + l]].theta[i] : 0.0;
              }
              ++col;
            }
          }
          for (std::size_t l = 0; l < na; ++l) p[l] = yprev[alive[a0 + l]];
          // Extras: input factor columns per lane, padded with ones to the group's most.
          std::size_t nf = 1;
          for (std::size_t l = 0; l < na; ++l) {
            const Job& job = jobs[alive[a0 + l]];
            if (job.extra >= 0) nf = std::max(nf, cands_[job.extra].in_cols.size());
          }
          ex_f.assign(lanes * nf, ones_.data());
          for (std::size_t l = 0; l < lanes; ++l) {
            const Job* job = l < na ? &jobs[alive[a0 + l]] : nullptr;
            const bool has = job != nullptr && job->extra >= 0;
            ex_q[l] = has ? cands_[job->extra].ypow : -1;
            ex_th[l] = has ? job->theta_extra : 0.0;
            if (!has) continue;
            const auto& fc = factor_cols_[job->extra];
            std::copy(fc.begin(),
                      fc.begin() + static_cast<std::ptrdiff_t>(cands_[job->extra].in_cols.size()),
                      ex_f.begin() + static_cast<std::ptrdiff_t>(l * nf));
          }
          for (std::size_t s0 = 0; s0 < len; s0 += kSubBlock) {
            const std::size_t sl = std::min(kSubBlock, len - s0);
            const double* th = theta;
            for (std::size_t q = 0; q < nq; ++q) {
              if (by_q[q].empty()) continue;  // LaneExtra writes c_q (zeros and extras)
              internal::LaneSums(static_cast<int>(nv), u_q[q].data(), g0 + s0, th, by_q[q].size(),
                                 sl, c + q * kSubBlock * lanes);
              th += by_q[q].size() * lanes;
            }
            internal::LaneExtra(static_cast<int>(nv), ex_f.data(), nf, g0 + s0, ex_th, ex_q, nq,
                                no_terms.data(), sl, c, kSubBlock);
            internal::LaneFreeRun(static_cast<int>(nv), nq, c, kSubBlock, y_.data() + g0 + s0,
                                  wn_.data() + g0 + s0, sl, lim, p, acc, bad);
          }
          for (std::size_t l = 0; l < na; ++l) {
            const std::size_t j = alive[a0 + l];
            Job& job = jobs[j];
            yprev[j] = p[l];
            job.cost += acc[l];
            if (bad[l] || !std::isfinite(job.cost)) {
              job.dead = job.diverged = true;
              job.cost = kInf;
            } else if (job.cost > bnd) {
              job.dead = true;
            }
          }
        }
      }
    }
  }

  void SimulateGeneral(const std::vector<int>& terms, std::span<Job> jobs,
                       const std::atomic<double>& bound, std::vector<double>& scratch) {
    std::vector<const double*> u(terms.size());
    for (std::size_t i = 0; i < terms.size(); ++i) u[i] = U(terms[i]).data();
    const double lim = spec_.divergence_limit;
    scratch.resize(kBlock);
    for (Job& job : jobs) {
      const Cand* ex = job.extra >= 0 ? &cands_[job.extra] : nullptr;
      for (const Segment& seg : segs_) {
        if (job.dead) break;
        std::vector<double> hist(seg.seed);  // simulated output, oldest first
        hist.reserve(seg.seed.size() + seg.len);
        const std::size_t off = seg.seed.size();
        for (std::size_t g0 = seg.start; g0 < seg.start + seg.len && !job.dead; g0 += kBlock) {
          const std::size_t len = std::min(kBlock, seg.start + seg.len - g0);
          if (ex != nullptr) Input(job.extra, g0, len, scratch.data());
          double cost = 0.0;
          bool bad = false;
          for (std::size_t s = 0; s < len; ++s) {
            const std::size_t k = off + (g0 - seg.start) + s;  // index into hist
            auto out_part = [&](const Cand& c) {
              double v = 1.0;
              for (const OutFactor& f : c.out) {
                v *= Pow(ApplyTransform(f.transform, f.exponent,
                                        hist[k - static_cast<std::size_t>(f.delay)]),
                         f.power);
              }
              return v;
            };
            double yk = 0.0;
            for (std::size_t i = 0; i < terms.size(); ++i) {
              yk += job.theta[i] * u[i][g0 + s] * out_part(cands_[terms[i]]);
            }
            if (ex != nullptr) yk += job.theta_extra * scratch[s] * out_part(*ex);
            const double e = y_[g0 + s] - yk;
            cost += wn_[g0 + s] * e * e;
            bad |= !(std::fabs(yk) <= lim);
            hist.push_back(yk);
          }
          job.cost += cost;
          if (bad || !std::isfinite(job.cost)) {
            job.dead = job.diverged = true;
            job.cost = kInf;
          } else if (job.cost > bound.load(std::memory_order_relaxed)) {
            job.dead = true;
          }
        }
      }
    }
  }

  const SemSpec& spec_;
  int threads_;
  bool fast_ = true;
  std::size_t n_ = 0;
  std::vector<double> y_, wn_;
  std::vector<Segment> segs_;
  std::vector<std::vector<std::vector<int>>> col_index_;  // [regressor][delay][power]
  std::vector<std::vector<double>> cols_;
  std::vector<std::vector<int>> base_index_;  // [regressor][delay] -> base_
  std::vector<std::vector<double>> base_;     // transformed signal, power 1
  std::vector<Cand> cands_;
  std::vector<std::vector<const double*>> factor_cols_;  // per candidate: Phi's columns
  std::vector<double> ones_;                             // n_ ones (pads factor lists)
  std::unordered_map<int, std::vector<double>> cross_;
  std::unordered_map<int, std::vector<double>> u_;
};

// Outcome of trying one candidate.
struct Trial {
  int cand = -1;
  double j = kInf;
  double rank = 0.0;  // one-step SSE reduction
  std::vector<double> theta;  // model terms then the candidate
};

class Search {
 public:
  Search(Engine& e, int threads) : e_(e), threads_(std::max(1, threads)) {}

  // Full-model free-run cost (no bound), +inf when diverging or singular.
  double Cost(const std::vector<int>& terms, std::vector<double>* theta) {
    if (!e_.Solve(terms, theta)) return kInf;
    if (terms.empty()) return e_.YtWy();
    return CostWith(terms, *theta, kInf);
  }

  double CostWith(const std::vector<int>& terms, const std::vector<double>& theta, double bnd) {
    Engine::Job job;
    job.theta = theta;
    std::atomic<double> bound{bnd};
    std::vector<double> scratch;
    e_.Simulate(terms, std::span<Engine::Job>(&job, 1), bound, scratch);
    return job.dead ? (job.diverged ? kInf : job.cost) : job.cost;
  }

  // Tries adding every eligible candidate. Returns the chosen trial (cand < 0: none
  // admissible). first: first-improvement with target j_threshold.
  // accept (optional): stress check of model + candidate with the trial's coefficients; a
  // candidate it refuses is skipped (counted in stress_rejected) for the next best.
  // limit > 0: simulate only the `limit` candidates of best one-step rank. bound0: only
  // candidates whose J is below it are admissible (early stop from the start).
  using Accept = std::function<bool(int cand, const std::vector<double>& theta)>;
  Trial TryAdd(const std::vector<int>& model, const std::vector<double>& w, bool first,
               double j_threshold, int* rejected, const Accept& accept = {},
               int* stress_rejected = nullptr, std::size_t limit = 0, double bound0 = kInf) {

    std::atomic<int> n_rejected{0};
    struct Report {
      std::atomic<int>& n;
      int* out;
      ~Report() { *out = n.load(); }
    } report{n_rejected, rejected};
    const std::size_t m = model.size();
    // Cholesky of the model Gram matrix.
    Eigen::MatrixXd g(m, m);
    for (std::size_t i = 0; i < m; ++i) {
      const auto& ci = e_.Cross(model[i]);
      for (std::size_t j = 0; j < m; ++j) g(i, j) = ci[model[j]];
    }
    Eigen::LLT<Eigen::MatrixXd> llt(g);
    std::vector<const std::vector<double>*> cross(m);
    for (std::size_t i = 0; i < m; ++i) cross[i] = &e_.Cross(model[i]);
    // Bordered LS for every candidate, and its one-step SSE reduction for ranking.
    const std::size_t nc = e_.num_candidates();
    std::vector<Trial> trials(nc);
    std::vector<char> in_model(nc, 0);
    for (int t : model) in_model[t] = 1;
    ParallelFor((nc + kChunk - 1) / kChunk, threads_, [&](std::size_t item, int) {
      Eigen::VectorXd gc(m), z(m);
      Eigen::Map<const Eigen::VectorXd> wv(w.data(), static_cast<Eigen::Index>(m));
      for (std::size_t c = item * kChunk; c < std::min(nc, (item + 1) * kChunk); ++c) {
        Trial& tr = trials[c];
        if (in_model[c]) continue;
        const Cand& cd = e_.cand(static_cast<int>(c));
        for (std::size_t i = 0; i < m; ++i) gc(i) = (*cross[i])[c];
        double sigma = cd.ss, r = cd.sy;
        if (m > 0) {
          z = llt.solve(gc);
          sigma -= gc.dot(z);
          r -= gc.dot(wv);
        }
        if (!(sigma > kCollinear * cd.ss) || !std::isfinite(sigma)) {
          ++n_rejected;
          continue;
        }
        const double th = r / sigma;
        tr.cand = static_cast<int>(c);
        tr.rank = r * r / sigma;
        tr.theta.resize(m + 1);
        for (std::size_t i = 0; i < m; ++i) tr.theta[i] = w[i] - z(i) * th;
        tr.theta[m] = th;
      }
    });
    std::vector<int> order;
    for (std::size_t c = 0; c < nc; ++c) {
      if (trials[c].cand >= 0) order.push_back(static_cast<int>(c));
    }
    // Rank by one-step criterion (largest SSE reduction first), ties by index.
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return trials[a].rank > trials[b].rank;
    });
    if (limit > 0 && order.size() > limit) order.resize(limit);
    Trial none;
    if (order.empty()) return none;
    auto accepted = [&](int c) {
      if (!accept || accept(c, trials[c].theta)) return true;
      if (stress_rejected != nullptr) ++*stress_rejected;
      return false;
    };
    // Admissible (finite J) candidates by J, ties by index, the first the check accepts.
    auto best_accepted = [&](std::vector<int> ok) {
      std::sort(ok.begin(), ok.end(), [&](int a, int b) {
        return trials[a].j != trials[b].j ? trials[a].j < trials[b].j : a < b;
      });
      for (int c : ok) {
        if (accepted(c)) return trials[c];
      }
      return none;
    };
    // Shared bound for early stopping. First improvement never lowers it below the
    // threshold, so no candidate that would meet the threshold is cut short.
    const double floor = first ? j_threshold : -kInf;
    std::atomic<double> best{bound0};
    for (int t : model) e_.U(t);  // materialise before the workers read them
    auto run_chunk = [&](std::size_t begin, std::size_t end, std::vector<double>& scratch) {
      std::vector<Engine::Job> jobs(end - begin);
      for (std::size_t i = begin; i < end; ++i) {
        Trial& tr = trials[order[i]];
        jobs[i - begin].theta.assign(tr.theta.begin(), tr.theta.end() - 1);
        jobs[i - begin].extra = tr.cand;
        jobs[i - begin].theta_extra = tr.theta.back();
      }
      e_.Simulate(model, jobs, best, scratch);
      for (std::size_t i = begin; i < end; ++i) {
        const Engine::Job& job = jobs[i - begin];
        Trial& tr = trials[order[i]];
        tr.j = job.dead ? kInf : job.cost;
        if (!job.dead) AtomicMin(best, std::max(job.cost, floor));
        if (job.diverged) ++n_rejected;
      }
    };
    if (!first) {
      const std::size_t chunks = (order.size() + kChunk - 1) / kChunk;
      std::vector<std::vector<double>> scratch(static_cast<std::size_t>(threads_));
      ParallelFor(chunks, threads_, [&](std::size_t item, int worker) {
        run_chunk(item * kChunk, std::min(order.size(), (item + 1) * kChunk), scratch[worker]);
      });
      std::vector<int> ok;
      for (int c : order) {
        if (trials[c].j < kInf) ok.push_back(c);
      }
      return best_accepted(std::move(ok));
    }
    // First improvement: rank order, in rounds of threads*kChunk candidates.
    const std::size_t round = static_cast<std::size_t>(threads_) * kChunk;
    std::vector<std::vector<double>> scratch(static_cast<std::size_t>(threads_));
    std::vector<int> fallback;
    for (std::size_t r0 = 0; r0 < order.size(); r0 += round) {
      const std::size_t r1 = std::min(order.size(), r0 + round);
      const std::size_t chunks = (r1 - r0 + kChunk - 1) / kChunk;
      ParallelFor(chunks, threads_, [&](std::size_t item, int worker) {
        run_chunk(r0 + item * kChunk, std::min(r1, r0 + (item + 1) * kChunk), scratch[worker]);
      });
      for (std::size_t i = r0; i < r1; ++i) {
        const int c = order[i];
        if (trials[c].j <= j_threshold && accepted(c)) return trials[c];
        if (trials[c].j < kInf && trials[c].j > j_threshold) fallback.push_back(c);
      }
    }
    return best_accepted(std::move(fallback));
  }

 private:
  Engine& e_;
  int threads_;
};

std::size_t SignalLine(const SemSpec& spec, const std::string& signal) {
  if (signal == spec.output) return spec.output_line;
  for (const auto& r : spec.regressors) {
    if (r.signal == signal) return r.signal_line;
  }
  return 0;
}

void CheckData(const SemSpec& spec, std::span<const DataSet> data) {
  for (const auto& d : data) {
    for (const auto& s : spec.Signals()) {
      if (!d.Has(s)) {
        throw InputError(spec.path, SignalLine(spec, s),
                         fmt::format("unknown column '{}': not in data file {}", s, d.path));
      }
    }
    if (d.rows() <= static_cast<std::size_t>(spec.MaxDelay()) + 1) {
      throw InputError(d.path, 0,
                       fmt::format("{} rows: too short for the spec's largest delay {}",
                                   d.rows(), spec.MaxDelay()));
    }
  }
}

}  // namespace

std::vector<ChannelInfo> ComputeScales(const SemSpec& spec, std::span<const DataSet> data) {
  CheckData(spec, data);
  std::vector<ChannelInfo> out;
  for (const auto& s : spec.Signals()) {
    ChannelInfo c;
    c.name = s;
    double mx = 0.0;
    for (const auto& d : data) {
      for (double v : d.Column(s)) mx = std::max(mx, std::fabs(v));
    }
    c.scale = mx > 0.0 ? mx : 1.0;
    out.push_back(c);
  }
  return out;
}

double SimulateCost(const SemSpec& spec, const std::vector<ChannelInfo>& channels,
                    const std::vector<SemTerm>& terms, const std::vector<double>& coefficients,
                    const DataSet& data, std::vector<double>* ysim) {
  const auto signals = spec.Signals();
  std::vector<const std::vector<double>*> col(signals.size());
  for (std::size_t i = 0; i < signals.size(); ++i) col[i] = &data.Column(signals[i]);
  std::vector<std::size_t> reg_channel(spec.regressors.size());
  for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
    reg_channel[r] = static_cast<std::size_t>(
        std::find(signals.begin(), signals.end(), spec.regressors[r].signal) - signals.begin());
  }
  const std::size_t n = data.rows();
  const std::size_t d0 = static_cast<std::size_t>(spec.MaxDelay());
  // Input regressors over the whole record (the output's are computed from the simulation).
  std::vector<std::vector<double>> input(spec.regressors.size());
  for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
    const std::size_t ci = reg_channel[r];
    if (ci != 0) input[r] = internal::TransformSignal(spec.regressors[r], *col[ci], channels[ci].scale);
  }
  std::vector<double> y(n);
  for (std::size_t k = 0; k < n; ++k) y[k] = (*col[0])[k] / channels[0].scale;
  std::vector<double> yh(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(std::min(d0, n)));
  yh.resize(n, 0.0);
  double cost = 0.0;
  bool bad = false;
  for (std::size_t k = d0; k < n; ++k) {
    double v = 0.0;
    for (std::size_t t = 0; t < terms.size(); ++t) {
      double tv = 1.0;
      for (const auto& f : terms[t].factors) {
        const auto& reg = spec.regressors[f.regressor];
        const std::size_t ci = reg_channel[f.regressor];
        const std::size_t kk = k - static_cast<std::size_t>(f.delay);
        const double value =
            ci == 0 ? ApplyTransform(reg.transform, reg.exponent, yh[kk]) : input[f.regressor][kk];
        tv *= Pow(value, f.power);
      }
      v += coefficients[t] * tv;
    }
    yh[k] = v;
    bad |= !(std::fabs(v) <= spec.divergence_limit);
    const double e = y[k] - v;
    const double w = spec.weighting == CostWeighting::kRelative
                         ? 1.0 / std::max(std::fabs(y[k]), spec.floor)
                         : 1.0;
    cost += w * e * e;
  }
  if (ysim != nullptr) *ysim = yh;
  if (bad || !std::isfinite(cost)) return kInf;
  return cost / static_cast<double>(n - d0);
}

int SelectIteration(const std::vector<SemIteration>& its, double tolerance_percent) {
  if (its.empty()) return 0;
  auto score = [](const SemIteration& it) {
    if (it.validation_j.empty()) return it.j;
    double s = 0.0;
    for (double v : it.validation_j) s += v;
    return s;
  };
  auto failed = [](const SemIteration& it) { return it.stress.checked && !it.stress.pass; };
  double best = kInf;
  for (const auto& it : its) {
    if (!failed(it)) best = std::min(best, score(it));
  }
  const SemIteration* pick = nullptr;
  for (const auto& it : its) {
    if (failed(it)) continue;
    const double s = score(it);
    if (!(s <= best * (1.0 + tolerance_percent / 100.0))) continue;
    if (pick == nullptr || it.terms.size() < pick->terms.size() ||
        (it.terms.size() == pick->terms.size() && s < score(*pick))) {
      pick = &it;
    }
  }
  if (pick == nullptr) {
    for (auto it = its.rbegin(); it != its.rend(); ++it) {
      if (!failed(*it)) return it->iteration;  // every passing score is infinite
    }
    return -1;
  }
  return pick->iteration;
}

SemResult Identify(const SemSpec& spec, std::span<const DataSet> identification,
                   std::span<const DataSet> validation, const SemOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (identification.empty()) throw InputError("", 0, "no identification data");
  CheckData(spec, identification);
  CheckData(spec, validation);
  SemResult res;
  res.channels = ComputeScales(spec, identification);
  RecordEnvelope(identification, &res.channels);
  const std::vector<DataSet> stress = BuildStressData(spec, identification);
  const Strategy strategy = o.strategy.value_or(spec.strategy);
  const double threshold = o.threshold_percent.value_or(spec.threshold_percent);
  const int max_it = o.max_iterations.value_or(spec.max_iterations);
  const double target = o.target_j.value_or(spec.target_j);
  const auto& initial = o.initial ? *o.initial : spec.initial;
  if (!std::isfinite(target)) {
    throw InputError(o.target_j ? "" : spec.path, 0,
                     fmt::format("target J {} is not a finite number", target));
  }
  if (!std::isfinite(threshold)) {
    throw InputError("", 0, fmt::format("threshold {} is not a finite number", threshold));
  }
  // Enough data for the parameters, and an output that varies.
  std::size_t samples = 0;
  for (const auto& d : identification) {
    samples += d.rows() - static_cast<std::size_t>(spec.MaxDelay());
  }
  const std::size_t max_params = samples / kMinSamplesPerParameter;
  if (max_params == 0) {
    throw InputError(identification.front().path, 0,
                     fmt::format("{} scored samples: identification needs at least {} samples "
                                 "per parameter",
                                 samples, kMinSamplesPerParameter));
  }
  for (const std::string& s : spec.Signals()) {
    double lo = kInf, hi = -kInf;
    for (const auto& d : identification) {
      for (const double v : d.Column(s)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
    if (lo < hi) continue;
    if (s == spec.output) {
      throw InputError(identification.front().path, 0,
                       fmt::format("output '{}' is constant ({}) in the identification data: "
                                   "nothing to identify",
                                   s, lo));
    }
    fmt::print(stderr, "warning: signal '{}' is constant ({}) in the identification data; its "
                       "terms cannot be told from the constant\n", s, lo);
  }
  SemSpec limited = spec;
  if (o.max_candidates) limited.max_candidates = *o.max_candidates;

  Engine eng(spec, identification, res.channels, o.threads);
  std::map<std::string, int> by_key;
  for (const SemTerm& t : GenerateCandidates(limited)) {
    by_key.emplace(TermKey(spec, t), eng.AddCandidate(t));
  }
  res.num_candidates = eng.num_candidates();
  res.fast_path = eng.fast();
  std::vector<int> model;
  for (const auto& text : initial) {
    const SemTerm t = ParseTerm(spec, text, o.initial ? "" : spec.path, 0);
    const std::string key = TermKey(spec, t);
    auto it = by_key.find(key);
    const int idx = it != by_key.end() ? it->second : eng.AddCandidate(t);
    by_key.emplace(key, idx);
    if (std::find(model.begin(), model.end(), idx) == model.end()) model.push_back(idx);
  }
  if (model.size() > max_params) {
    throw InputError("", 0,
                     fmt::format("initial structure has {} terms; {} scored samples allow at "
                                 "most {} ({} per parameter)",
                                 model.size(), samples, max_params, kMinSamplesPerParameter));
  }
  eng.PrepareCandidates();

  Search search(eng, o.threads);
  auto stress_of = [&](const std::vector<int>& terms, const std::vector<double>& th) {
    std::vector<SemTerm> t;
    for (int c : terms) t.push_back(eng.cand(c).term);
    return CheckStress(spec, res.channels, t, th, stress);
  };
  Search::Accept accept;  // none without [stress]
  if (!stress.empty()) {
    accept = [&](int cand, const std::vector<double>& th) {
      std::vector<int> terms = model;
      terms.push_back(cand);
      return stress_of(terms, th).pass;
    };
  }
  // The stress check of base + candidate (none without [stress]).
  auto accept_for = [&](const std::vector<int>& base) -> Search::Accept {
    if (stress.empty()) return {};
    return [&stress_of, base](int cand, const std::vector<double>& th) {
      std::vector<int> terms = base;
      terms.push_back(cand);
      return stress_of(terms, th).pass;
    };
  };
  std::vector<internal::Evaluator> evaluators;  // for the output-error refinement
  if (spec.refine) {
    for (const DataSet& d : identification) evaluators.emplace_back(spec, res.channels, d);
  }
  std::vector<double> theta;
  double j = search.Cost(model, &theta);
  auto validate = [&](const std::vector<SemTerm>& terms, const std::vector<double>& coefficients) {
    std::vector<double> vj;
    for (const auto& v : validation) {
      vj.push_back(SimulateCost(spec, res.channels, terms, coefficients, v));
    }
    return vj;
  };
  // The refinement of a recorded iteration does not feed the search: with two or more threads
  // it runs beside the search of the next iteration (one at a time, so the iterations are
  // completed, reported and stored in order). Its results are the same either way.
  std::future<void> refining;
  auto finish_recorded = [&refining] {
    if (refining.valid()) refining.get();
  };
  auto record = [&](int iteration, int rejected, int stress_rejected) {
    SemIteration it;
    it.iteration = iteration;
    it.rejected = rejected;
    it.stress_rejected = stress_rejected;
    for (int t : model) it.terms.push_back(eng.cand(t).term);
    it.coefficients = theta;
    it.j = j;
    it.stress = stress_of(model, theta);
    it.validation_j = validate(it.terms, theta);
    // Output-error refinement, kept when it lowers J, passes the stress check as the least
    // squares did, and (with validation data) makes no validation set's J worse.
    auto complete = [&, it = std::move(it), terms = model]() mutable {
      if (spec.refine && !terms.empty()) {
        std::vector<double> refined = it.coefficients;
        const double jr = internal::RefineFreeRun(evaluators, it.terms, &refined);
        const bool lower = jr < it.j;
        const StressVerdict sv = lower ? stress_of(terms, refined) : StressVerdict{};
        const std::vector<double> vj = lower ? validate(it.terms, refined) : std::vector<double>{};
        bool no_worse = true;  // on every validation set
        for (std::size_t i = 0; i < vj.size(); ++i) no_worse &= vj[i] <= it.validation_j[i];
        if (lower && (sv.pass || !it.stress.pass) && no_worse) {
          it.coefficients = std::move(refined);
          it.j = jr;
          it.stress = sv;
          it.validation_j = vj;
        }
      }
      it.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (o.progress) o.progress(it);
      res.iterations.push_back(std::move(it));
    };
    finish_recorded();
    if (spec.refine && o.threads > 1) {
      refining = std::async(std::launch::async, std::move(complete));
    } else {
      complete();
    }
  };
  // Pruning: drop the term whose removal gives the lowest J while that J is below j_prev.
  auto prune = [&](double j_prev) {
    while (model.size() > 1) {
      double best = kInf;
      std::size_t drop = 0;
      std::vector<double> best_theta;
      for (std::size_t i = 0; i < model.size(); ++i) {
        std::vector<int> reduced = model;
        reduced.erase(reduced.begin() + static_cast<std::ptrdiff_t>(i));
        std::vector<double> th;
        if (!eng.Solve(reduced, &th)) continue;
        const double jr = search.CostWith(reduced, th, std::min(best, j_prev));
        if (jr < best) {
          best = jr;
          drop = i;
          best_theta = th;
        }
      }
      if (!(best < j_prev)) break;
      if (accept) {  // a pruned model must pass the stress check too
        std::vector<int> reduced = model;
        reduced.erase(reduced.begin() + static_cast<std::ptrdiff_t>(drop));
        if (!stress_of(reduced, best_theta).pass) break;
      }
      model.erase(model.begin() + static_cast<std::ptrdiff_t>(drop));
      theta = best_theta;
      j = best;
    }
  };
  // Best single exchange: for every term, the candidate that best replaces it (among the
  // exchange_pool best by one-step rank); applied when it lowers J. False when none does.
  auto exchange = [&](int* rejected, int* stress_rejected) {
    double best_j = j * (1.0 - kExchangeGain);
    Trial best;
    std::vector<int> best_model;
    for (std::size_t i = 0; i < model.size(); ++i) {
      std::vector<int> reduced = model;
      reduced.erase(reduced.begin() + static_cast<std::ptrdiff_t>(i));
      std::vector<double> th;
      if (!eng.Solve(reduced, &th)) continue;
      int rej = 0;
      const Trial tr = search.TryAdd(reduced, th, false, -kInf, &rej, accept_for(reduced),
                                     stress_rejected, kExchangePool, best_j);
      *rejected += rej;
      if (tr.cand >= 0 && tr.cand != model[i] && tr.j < best_j) {
        best_j = tr.j;
        best = tr;
        best_model = std::move(reduced);
      }
    }
    if (best.cand < 0) return false;
    model = std::move(best_model);
    model.push_back(best.cand);
    theta = best.theta;
    j = best.j;
    return true;
  };
  // One search path from the current model: iteration 0 is the start, then add (first or
  // best improvement), prune, exchange, until target_j, max_iterations or no admissible term.
  const int exchanges = spec.exchange ? kMaxExchanges : 0;
  auto run_path = [&]() {
    j = search.Cost(model, &theta);
    record(0, 0, 0);
    for (int iteration = 1; iteration <= max_it; ++iteration) {
      if (j <= target) break;
      if (model.size() + 1 > max_params) break;  // kMinSamplesPerParameter
      const double j_prev = j;
      int rejected = 0;
      int stress_rejected = 0;
      const Trial tr = search.TryAdd(model, theta, strategy == Strategy::kFirst,
                                     j_prev * (1.0 - threshold / 100.0), &rejected, accept,
                                     &stress_rejected);
      if (tr.cand < 0) {  // nothing admissible
        res.exhausted_rejected = rejected;
        break;
      }
      model.push_back(tr.cand);
      j = search.Cost(model, &theta);
      prune(j_prev);
      // Exchange: replace one term by a candidate while that lowers J, then prune again.
      for (int pass = 0; pass < exchanges && exchange(&rejected, &stress_rejected); ++pass) {
        prune(j_prev);
      }
      record(iteration, rejected, stress_rejected);
    }
    finish_recorded();
  };
  const std::vector<int> initial_model = model;
  run_path();
  // Second start: the structure the one-step (prediction-error) criterion selects by forward
  // regression, stopped by BIC on its one-step SSE, then pruned by J. Escapes the lock-in of
  // the greedy search when a single added term cannot show the gain of a pair (a lightly
  // damped resonance needs y(k-1) and y(k-2) together).
  if (initial.empty() && spec.one_step_start) {
    std::vector<SemIteration> first_path = std::move(res.iterations);
    res.iterations.clear();
    double yty = 0.0;
    for (const auto& d : identification) {
      const auto& y = d.Column(spec.output);
      for (std::size_t k = static_cast<std::size_t>(spec.MaxDelay()); k < y.size(); ++k) {
        yty += (y[k] / res.channels[0].scale) * (y[k] / res.channels[0].scale);
      }
    }
    const double n = static_cast<double>(samples);
    model.clear();
    theta.clear();
    double sse = yty, bic = n * std::log(std::max(yty, 1e-300) / n);
    while (model.size() + 1 <= max_params) {
      int rej = 0;
      const Trial tr = search.TryAdd(model, theta, false, -kInf, &rej, accept, nullptr, 1);
      if (tr.cand < 0) break;
      const double sse_new = sse - tr.rank;
      const double bic_new = n * std::log(std::max(sse_new, 1e-300) / n) +
                             static_cast<double>(model.size() + 1) * std::log(n);
      if (!(bic_new < bic)) break;
      model.push_back(tr.cand);
      theta = tr.theta;
      sse = sse_new;
      bic = bic_new;
    }
    j = search.Cost(model, &theta);
    for (double before = kInf; j < before;) {
      before = j;
      prune(before);
    }
    const std::vector<int> start = model;
    run_path();
    std::vector<SemIteration> second_path = std::move(res.iterations);
    // Select over both paths (second path renumbered after the first), keep the picked one.
    const int offset = static_cast<int>(first_path.size());
    res.iterations = std::move(first_path);
    for (SemIteration it : second_path) {
      it.iteration += offset;
      res.iterations.push_back(std::move(it));
    }
    internal::SelectModel(spec, identification, o.threads, &res);
    const bool second = res.selected >= offset;  // keep the picked path (with its CV costs)
    if (second) {
      res.iterations.erase(res.iterations.begin(), res.iterations.begin() + offset);
      for (SemIteration& it : res.iterations) it.iteration -= offset;
      res.selected -= offset;
    } else {
      res.iterations.resize(static_cast<std::size_t>(offset));
    }
    res.selection_rule += fmt::format(
        "; over two search starts, kept: {} (the {}-term one-step forward-regression start {})",
        second ? "the one-step start" : "the initial structure", start.size(),
        second ? "won" : "lost");
  } else {
    internal::SelectModel(spec, identification, o.threads, &res);
  }
  if (res.selected < 0) {
    throw InputError(spec.path, spec.stress.line,
                     "no iteration passes the stress check ([stress]): nothing to select");
  }
  return res;
}

}  // namespace mrd::host
