#include "sem/engine/engine.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>

#include "mrd/host/input_error.hpp"
#include "sem/internal.hpp"

namespace mrd::host::internal {

Engine::Engine(const SemSpec& spec, std::span<const DataSet> data,
               const std::vector<ChannelInfo>& ch, int threads)
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
      transformed[d] = TransformSignal(reg, data[d].Column(reg.signal), ch[ci].scale);
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

int Engine::AddCandidate(const SemTerm& t) {
  Cand c;
  c.term = t;
  for (const auto& f : t.factors) {
    const auto& reg = spec_.regressors[f.regressor];
    if (f.power < 1 || f.power > static_cast<int>(kMaxPower) || f.delay < 0 ||
        f.delay > static_cast<int>(kMaxDelay)) {
      throw InputError("", 0,
                       fmt::format("bad term '{}': power {} or delay {} out of range",
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

void Engine::PrepareCandidates() {
  std::vector<double> ss(cands_.size()), sy(cands_.size());
  GramSums(nullptr, ss.data());
  GramSums(y_.data(), sy.data());
  for (std::size_t c = 0; c < cands_.size(); ++c) {
    cands_[c].ss = ss[c];
    cands_[c].sy = sy[c];
  }
}

const std::vector<double>& Engine::Cross(int t) {
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

const std::vector<double>& Engine::U(int t) {
  auto it = u_.find(t);
  if (it != u_.end()) return it->second;
  std::vector<double> u(n_);
  for (std::size_t g0 = 0; g0 < n_; g0 += kBlock) {
    Input(t, g0, std::min(kBlock, n_ - g0), u.data() + g0);
  }
  return u_.emplace(t, std::move(u)).first->second;
}

bool Engine::Solve(const std::vector<int>& terms, std::vector<double>* theta) {
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

void Engine::Simulate(const std::vector<int>& terms, std::span<Job> jobs,
                      const std::atomic<double>& bound, std::vector<double>& scratch) {
  if (fast_) {
    SimulateFast(terms, jobs, bound, scratch);
  } else {
    SimulateGeneral(terms, jobs, bound, scratch);
  }
}

double Engine::YtWy() const {
  double s = 0.0;
  for (std::size_t g = 0; g < n_; ++g) s += wn_[g] * y_[g] * y_[g];
  return s;
}

void Engine::GramSums(const double* x, double* out) {
  const std::size_t items = (cands_.size() + kGramItem - 1) / kGramItem;
  ParallelFor(items, threads_, [&](std::size_t item, int) { GramItem(item, x, out); });
}

void Engine::GramItem(std::size_t item, const double* x, double* out) const {
  const std::size_t c_begin = item * kGramItem;
  const std::size_t c_end = std::min(cands_.size(), c_begin + kGramItem);
  // Per group of 4 vectors: factor columns [lane * nf + k], padded with ones.
  const std::size_t width = LaneWidth(), group = 4 * width;
  std::vector<std::vector<const double*>> f;
  std::vector<std::size_t> nf;
  for (std::size_t c0 = c_begin; c0 < c_end; c0 += group) {
    const std::size_t nc = std::min(group, c_end - c0);
    const std::size_t lanes = (nc + width - 1) / width * width;
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
  std::vector<double> acc(f.size() * group, 0.0);
  for (std::size_t g0 = 0; g0 < n_; g0 += kBlock) {
    const std::size_t len = std::min(kBlock, n_ - g0);
    for (std::size_t g = 0; g < f.size(); ++g) {
      const int nv = static_cast<int>(f[g].size() / nf[g] / width);
      LaneGram(nv, f[g].data(), nf[g], g0, x, len, &acc[g * group]);
    }
  }
  std::copy(acc.begin(), acc.begin() + static_cast<std::ptrdiff_t>(c_end - c_begin), out + c_begin);
}

void Engine::Input(int c, std::size_t g0, std::size_t len, double* out) const {
  Product(factor_cols_[c].data(), cands_[c].in_cols.size(), g0, len, out);
}

void Engine::Phi(int c, std::size_t g0, std::size_t len, double* out) const {
  Product(factor_cols_[c].data(), factor_cols_[c].size(), g0, len, out);
}

void Engine::SimulateFast(const std::vector<int>& terms, std::span<Job> jobs,
                          const std::atomic<double>& bound, std::vector<double>& scratch) {
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
  const std::size_t width = LaneWidth(), group = 4 * width;  // jobs per lane group
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
      for (std::size_t a0 = 0; a0 < alive.size(); a0 += group) {
        const std::size_t na = std::min(group, alive.size() - a0);
        const std::size_t nv = (na + width - 1) / width;
        const std::size_t lanes = nv * width;  // unused lanes: theta 0, output 0
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
            LaneSums(static_cast<int>(nv), u_q[q].data(), g0 + s0, th, by_q[q].size(), sl,
                     c + q * kSubBlock * lanes);
            th += by_q[q].size() * lanes;
          }
          LaneExtra(static_cast<int>(nv), ex_f.data(), nf, g0 + s0, ex_th, ex_q, nq,
                    no_terms.data(), sl, c, kSubBlock);
          LaneFreeRun(static_cast<int>(nv), nq, c, kSubBlock, y_.data() + g0 + s0,
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

void Engine::SimulateGeneral(const std::vector<int>& terms, std::span<Job> jobs,
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

}  // namespace mrd::host::internal
