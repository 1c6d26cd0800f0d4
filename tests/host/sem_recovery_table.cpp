// Counts table of the structure-recovery suite (sem_recovery.hpp): exact recoveries of the
// selected model per system, noise and record length, default settings, no validation data.
//   build/tests/sem_recovery [--seeds N] [--strategy best|first] [--threads N] [--before]
//   [--misses]
//   [--trace SYSTEM EE|OE|MA N SEED]   (every iteration of one case, * = selected)
//   [--case SYSTEM EE|OE|MA N]          (the count and misses of one case only)
//   [--oracle SYSTEM EE|OE|MA N]        (the one-step least-squares oracle of one case)
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "sem_recovery.hpp"

namespace {

// One-step least-squares oracle of one case: for each seed, whether the true structure has the
// lowest one-step squared error among ALL structures of its size built from the spec's
// candidates (exhaustive). Under Gaussian equation-error noise that error is the likelihood,
// so no rule that compares models of equal size by likelihood (any penalty on the number of
// terms: AIC, BIC, ...) selects the truth in a seed the oracle misses. Prints the count and,
// before it, per missed seed, the winner and the relative margin of the truth.
void Oracle(const mrd::test::RecoverySystem& sys, mrd::test::Noise noise, std::size_t n, int seeds,
            const std::string& spec_text) {
  const mrd::host::SemSpec spec = mrd::host::ParseSemSpec(spec_text, "recovery.toml");
  const std::vector<mrd::host::SemTerm> cands = mrd::host::GenerateCandidates(spec);
  const std::size_t nc = cands.size(), size = sys.terms.size();
  std::vector<int> truth;
  for (std::size_t c = 0; c < nc; ++c) {
    if (sys.terms.count(mrd::host::TermName(spec, cands[c])) != 0) {
      truth.push_back(static_cast<int>(c));
    }
  }
  int hits = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    const mrd::host::DataSet d = mrd::test::SuiteData(sys, noise, n, seed);
    const auto& y = d.Column("y");
    const std::size_t k0 = 2, rows = n - k0;  // samples with both delays available
    Eigen::MatrixXd phi(rows, nc);
    Eigen::VectorXd yv(rows);
    for (std::size_t k = k0; k < n; ++k) {
      yv(k - k0) = y[k];
      for (std::size_t c = 0; c < nc; ++c) {
        double v = 1.0;
        for (const auto& f : cands[c].factors) {
          const auto& sig = d.Column(spec.regressors[f.regressor].signal);
          v *= std::pow(sig[k - static_cast<std::size_t>(f.delay)], f.power);
        }
        phi(k - k0, c) = v;
      }
    }
    const Eigen::MatrixXd g = phi.transpose() * phi;
    const Eigen::VectorXd b = phi.transpose() * yv;
    auto sse = [&](const std::vector<int>& set) {
      const auto m = static_cast<Eigen::Index>(set.size());
      Eigen::MatrixXd gs(m, m);
      Eigen::VectorXd bs(m);
      for (Eigen::Index i = 0; i < m; ++i) {
        bs(i) = b(set[i]);
        for (Eigen::Index j = 0; j < m; ++j) gs(i, j) = g(set[i], set[j]);
      }
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(gs);
      return yv.squaredNorm() - bs.dot(ldlt.solve(bs));
    };
    const double s_true = sse(truth);
    double s_best = s_true;
    std::vector<int> best = truth;
    // Every subset of `size` candidates, in lexicographic order.
    std::vector<int> idx(size);
    for (std::size_t i = 0; i < size; ++i) idx[i] = static_cast<int>(i);
    while (true) {
      const double s = sse(idx);
      if (s < s_best && idx != truth) {
        s_best = s;
        best = idx;
      }
      std::size_t i = size;
      while (i > 0 && idx[i - 1] == static_cast<int>(nc - size + i - 1)) --i;
      if (i == 0) break;
      ++idx[i - 1];
      for (std::size_t j = i; j < size; ++j) idx[j] = idx[j - 1] + 1;
    }
    if (best == truth) {
      ++hits;
      continue;
    }
    std::printf("seed %d:", seed);
    for (int c : best) {
      std::printf(" %s", mrd::host::TermName(spec, cands[static_cast<std::size_t>(c)]).c_str());
    }
    std::printf("  (truth %.3g %% higher)\n", 100.0 * (s_true / s_best - 1.0));
  }
  std::printf("%s %s N=%zu one-step LS oracle: %d/%d\n", sys.name.c_str(),
              mrd::test::NoiseName(noise), n, hits, seeds);
}

// Every iteration of one seed's run (* = selected), the selection rule, and the true
// structure's least-squares J and cross-validated J for comparison.
void Trace(const mrd::test::RecoverySystem& s, mrd::test::Noise noise, std::size_t n, int seed,
           const mrd::host::SemOptions& o, const std::string& spec) {
  const mrd::host::SemSpec sp = mrd::host::ParseSemSpec(spec, "recovery.toml");
  const std::vector<mrd::host::DataSet> id{mrd::test::SuiteData(s, noise, n, seed)};
  const auto r = mrd::host::Identify(sp, id, {}, o);
  for (const auto& it : r.iterations) {
    double cv = 0.0;
    for (double v : it.cv_j) cv += v;
    std::printf("%s%2d J %.6g CV %.6g:", it.iteration == r.selected ? "*" : " ", it.iteration, it.j,
                cv);
    for (const auto& t : it.terms) std::printf(" %s", mrd::host::TermName(sp, t).c_str());
    std::printf("\n");
  }
  std::printf("%s\n", r.selection_rule.c_str());
  mrd::host::SemOptions t = o;  // the true structure, least squares, no search
  t.initial = std::vector<std::string>(s.terms.begin(), s.terms.end());
  t.max_iterations = 0;
  const auto truth = mrd::host::Identify(sp, id, {}, t);
  double tcv = 0.0;
  for (double v : truth.iterations.front().cv_j) tcv += v;
  std::printf("true structure: J %.6g CV %.6g\n", truth.iterations.front().j, tcv);
}

}  // namespace

int main(int argc, char** argv) try {
  int seeds = 20;
  bool misses = false;
  std::string spec = mrd::test::kRecoverySpec;
  mrd::host::SemOptions o;
  o.threads = 2;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) {
      seeds = std::atoi(argv[++i]);
    } else if (a == "--threads" && i + 1 < argc) {
      o.threads = std::atoi(argv[++i]);
    } else if (a == "--strategy" && i + 1 < argc) {
      const std::string s = argv[++i];
      o.strategy = s == "first" ? mrd::host::Strategy::kFirst : mrd::host::Strategy::kBest;
    } else if (a == "--before") {  // the rules before issue 15: best, 5 % tolerance
      spec = std::string(mrd::test::kRecoverySpec) +
             "[algorithm]\nstrategy = \"best\"\nselection = \"tolerance\"\n";
    } else if (a == "--misses") {
      misses = true;
    } else if ((a == "--case" || a == "--oracle" || a == "--trace") &&
               i + (a == "--trace" ? 4 : 3) < argc) {  // SYSTEM EE|OE|MA N [SEED]: one case
      const mrd::test::RecoverySystem& s = mrd::test::RecoverySystemNamed(argv[i + 1]);
      const std::string nz = argv[i + 2];
      const auto noise = mrd::test::NoiseNamed(nz);
      const auto n = static_cast<std::size_t>(std::atoi(argv[i + 3]));
      if (a == "--case") {  // one count, with misses
        const auto c = mrd::test::CountRecovered(s, noise, n, seeds, o, spec);
        std::printf("%s %s N=%zu: %d/%d\n%s", s.name.c_str(), nz.c_str(), n, c.hits, c.seeds,
                    c.misses.c_str());
      } else if (a == "--oracle") {
        Oracle(s, noise, n, seeds, spec);
      } else {
        Trace(s, noise, n, std::atoi(argv[i + 4]), o, spec);
      }
      return 0;
    } else {
      std::fprintf(stderr,
                   "usage: sem_recovery [--seeds N] [--strategy best|first] "
                   "[--threads N] [--before] [--misses] [--trace SYSTEM EE|OE|MA N SEED] "
                   "[--case SYSTEM EE|OE|MA N] [--oracle SYSTEM EE|OE|MA N]\n");
      return 2;
    }
  }
  std::printf("%-10s %-6s %6s %6s\n", "system", "noise", "N=1000", "N=500");
  for (const auto& s : mrd::test::RecoverySystems()) {
    for (const auto noise : s.noises) {
      const auto a = mrd::test::CountRecovered(s, noise, 1000, seeds, o, spec);
      const auto b = mrd::test::CountRecovered(s, noise, 500, seeds, o, spec);
      std::printf("%-10s %-6s %3d/%-2d %3d/%-2d\n", s.name.c_str(), mrd::test::NoiseName(noise),
                  a.hits, a.seeds, b.hits, b.seeds);
      if (misses) std::printf("%s%s", a.misses.c_str(), b.misses.c_str());
      std::fflush(stdout);
    }
  }
  return 0;
} catch (const std::exception& e) {  // an unknown SYSTEM
  std::fprintf(stderr, "sem_recovery: %s\n", e.what());
  return 2;
}
