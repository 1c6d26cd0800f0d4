#pragma once
// The SEM engine's data and free runs (used by host/src/sem/identify.cpp's Identify through Search,
// host/src/sem/search/search.hpp): the identification records stacked and normalised, the
// elementary power columns, the candidates with their Gram sums, and the free run of many jobs at
// once (host/src/sem/engine/kernels.hpp gives the cost model). Not public.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <span>
#include <thread>
#include <unordered_map>
#include <vector>

#include "mrd/host/sem.hpp"
#include "sem/engine/kernels.hpp"
#include "sem/internal.hpp"

namespace mrd::host::internal {

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

// b^p by repeated multiplication (p >= 0; the same bits as the firmware's evaluation).
inline double Pow(double b, int p) {
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
  std::vector<int> in_cols;    // elementary power columns of the input factors
  std::vector<int> out_cols;   // ... of the output factors (measured output, one-step)
  std::vector<OutFactor> out;  // output factors, for the general free run
  int ypow = 0;                // fast path: power of y(k-1)
  double ss = 0.0;             // phi' phi
  double sy = 0.0;             // phi' y
};

// Everything the search needs about the identification data.
class Engine {
 public:
  Engine(const SemSpec& spec, std::span<const DataSet> data, const std::vector<ChannelInfo>& ch,
         int threads);

  // Registers a candidate term; returns its index.
  int AddCandidate(const SemTerm& t);

  // phi'phi and phi'y of every candidate (sums in sample order).
  void PrepareCandidates();

  std::size_t num_candidates() const { return cands_.size(); }
  const Cand& cand(int c) const { return cands_[c]; }
  bool fast() const { return fast_; }
  double divergence_limit() const { return spec_.divergence_limit; }

  // Cross products phi_t' phi_c for every candidate c (cached; sums in sample order,
  // a lane group of candidates at a time).
  const std::vector<double>& Cross(int t);

  // Input part of a candidate, whole stacked length (cached).
  const std::vector<double>& U(int t);

  // LS on the one-step regression for a set of terms; false when singular.
  bool Solve(const std::vector<int>& terms, std::vector<double>* theta);

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
  void Simulate(const std::vector<int>& terms, std::span<Job> jobs,
                const std::atomic<double>& bound, std::vector<double>& scratch);

  std::size_t n() const { return n_; }
  double YtWy() const;  // sum of w y^2: the cost of the empty model

 private:
  static constexpr std::size_t kBlock = 256;  // samples per block of the free-run pass

  // out[c] = sum_k phi_c(k) x(k) for every candidate c (x == nullptr: phi_c(k)^2), summed in
  // sample order, a lane group of candidates at a time (host/src/sem/engine/kernels.hpp).
  void GramSums(const double* x, double* out);

  // GramSums of the candidates [item * kGramItem, ...): one sweep over the samples for all of
  // them (a block's columns stay in cache).
  static constexpr std::size_t kGramItem = 4 * kMaxLanes;  // a multiple of every group size
  void GramItem(std::size_t item, const double* x, double* out) const;

  // Input part of candidate c (product of its input factors; 1 without) over [g0, g0 + len).
  void Input(int c, std::size_t g0, std::size_t len, double* out) const;

  // Regressor of candidate c (input then output factors, measured output).
  void Phi(int c, std::size_t g0, std::size_t len, double* out) const;

  int ExtraPow(const Job& j) const { return j.extra >= 0 ? cands_[j.extra].ypow : -1; }

  // Free run of the fast path (y(k-1) only): y(k) = sum_q c_q(k) y(k-1)^q with
  // c_q(k) = sum over terms of y-power q of theta_i u_i(k) (+ the job's extra candidate).
  // Jobs go through in lane groups of 4 vectors (host/src/sem/engine/kernels.hpp gives the
  // cost model); the bound is checked every kBlock samples, as are divergence and finiteness.
  void SimulateFast(const std::vector<int>& terms, std::span<Job> jobs,
                    const std::atomic<double>& bound, std::vector<double>& scratch);

  // Free run of any model (output factors at any delay and transform), one job at a time.
  void SimulateGeneral(const std::vector<int>& terms, std::span<Job> jobs,
                       const std::atomic<double>& bound, std::vector<double>& scratch);

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

}  // namespace mrd::host::internal
