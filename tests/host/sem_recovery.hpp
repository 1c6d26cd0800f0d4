#pragma once
// Structure-recovery suite (issue 15): classic polynomial NARX systems of the
// structure-selection literature, simulated with equation-error (EE) or output-error (OE)
// noise, identified by SEM with the DEFAULT algorithm settings and no validation data. A seed
// counts as recovered when the selected model's terms are exactly the true ones. Used by
// sem_recovery_test.cpp (CTest label sem) and the sem_recovery table tool.

#include <cstdint>
#include <functional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "mrd/host/sem.hpp"
#include "mrd/host/sem_spec.hpp"
#include "sem_test_util.hpp"

namespace mrd::test {

// Candidates: y(k-1), y(k-2), u(k-1), u(k-2), products up to degree 3, a constant: 35 terms.
// No [algorithm] table: every algorithm setting at its built-in default.
inline constexpr const char* kRecoverySpec = R"(output = "y"
[[regressor]]
name = "y"
signal = "y"
powers = [1, 2, 3]
delays = [1, 2]
[[regressor]]
name = "u"
signal = "u"
powers = [1, 2, 3]
delays = [1, 2]
[limits]
max_factors = 3
max_degree = 3
constant = true
[cost]
weighting = "mse"
)";

enum class Noise { kEquation, kOutput };

// One system: next noise-free output from (y(k-1), y(k-2), u(k-1), u(k-2)), its true terms,
// and the noise standard deviation (input u uniform on [-1, 1]).
struct RecoverySystem {
  std::string name;
  std::function<double(double, double, double, double)> f;
  std::set<std::string> terms;
  double sigma = 0.0;
};

inline std::vector<RecoverySystem> RecoverySystems() {
  return {
      // Billings-style test system (e.g. Mao & Billings 1997; Piroddi & Spinelli 2003).
      {"billings",
       [](double y1, double y2, double u1, double u2) {
         return 0.5 * y1 + 0.8 * u2 + u1 * u1 - 0.05 * y2 * y2;
       },
       {"y(k-1)", "u(k-2)", "u(k-1)^2", "y(k-2)^2"},
       0.1},
      // Piroddi & Spinelli 2003, example 1 (misleads prediction-error selection under OE noise).
      {"piroddi",
       [](double, double y2, double u1, double) { return 0.75 * y2 + 0.25 * u1 - 0.2 * y2 * u1; },
       {"y(k-2)", "u(k-1)", "y(k-2)*u(k-1)"},
       0.05},
      // Wei & Billings 2008 (integrated forward orthogonal search), example 1.
      {"wei",
       [](double y1, double y2, double u1, double u2) {
         return -0.605 * y1 - 0.163 * y2 * y2 + 0.588 * u1 - 0.24 * u2;
       },
       {"y(k-1)", "y(k-2)^2", "u(k-1)", "u(k-2)"},
       0.04},
      // Lightly damped linear second order: poles 0.75 +- 0.58i (radius 0.949, damping
      // ratio 0.08); the case where greedy best improvement locks in on a product term.
      {"linear2",
       [](double y1, double y2, double u1, double u2) {
         return 1.5 * y1 - 0.9 * y2 + 0.5 * u1 + 0.3 * u2;
       },
       {"y(k-1)", "y(k-2)", "u(k-1)", "u(k-2)"},
       0.1},
  };
}

// n samples of a system (after 200 samples of warm-up), noise seeded by seed.
inline host::DataSet RecoveryData(const RecoverySystem& s, Noise noise, std::uint64_t seed,
                                  std::size_t n) {
  Gauss g(seed);
  const std::size_t warm = 200, total = n + warm;
  std::vector<double> u(total), w(total, 0.0), y(total, 0.0);
  for (auto& v : u) v = 2.0 * g.Uniform() - 1.0;
  for (std::size_t k = 2; k < total; ++k) {
    if (noise == Noise::kEquation) {
      y[k] = s.f(y[k - 1], y[k - 2], u[k - 1], u[k - 2]) + s.sigma * g();
    } else {
      w[k] = s.f(w[k - 1], w[k - 2], u[k - 1], u[k - 2]);
    }
  }
  if (noise == Noise::kOutput) {
    for (std::size_t k = 0; k < total; ++k) y[k] = w[k] + s.sigma * g();
  }
  u.erase(u.begin(), u.begin() + static_cast<std::ptrdiff_t>(warm));
  y.erase(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(warm));
  return MakeDataSet("sim", {"u", "y"}, {u, y});
}

// The system of RecoverySystems() called name; throws std::runtime_error when there is none.
inline const RecoverySystem& RecoverySystemNamed(const std::string& name) {
  static const std::vector<RecoverySystem> all = RecoverySystems();
  for (const auto& s : all) {
    if (s.name == name) return s;
  }
  throw std::runtime_error("no recovery system '" + name + "'");
}

// The suite's record of one seed (seeds 1, 2, ... of CountRecovered).
inline host::DataSet SuiteData(const RecoverySystem& s, Noise noise, std::size_t n, int seed) {
  return RecoveryData(s, noise, 7919u * static_cast<std::uint64_t>(seed) + n, n);
}

// Term names of the selected iteration of a result.
inline std::set<std::string> SelectedTerms(const host::SemSpec& spec, const host::SemResult& r) {
  std::set<std::string> out;
  for (const auto& it : r.iterations) {
    if (it.iteration != r.selected) continue;
    for (const auto& t : it.terms) out.insert(host::TermName(spec, t));
  }
  return out;
}

struct RecoveryCount {
  int hits = 0;
  int seeds = 0;
  std::string misses;  // one line per missed seed: its selected terms
};

// Identifies every seed 1 ... seeds with the default settings (options: threads only) and no
// validation data; counts exact recoveries of the selected model.
inline RecoveryCount CountRecovered(const RecoverySystem& s, Noise noise, std::size_t n,
                                    int seeds, const host::SemOptions& options = {},
                                    const std::string& spec_text = kRecoverySpec) {
  const host::SemSpec spec = host::ParseSemSpec(spec_text, "recovery.toml");
  RecoveryCount out;
  for (int seed = 1; seed <= seeds; ++seed) {
    const std::vector<host::DataSet> id{SuiteData(s, noise, n, seed)};
    const host::SemResult r = host::Identify(spec, id, {}, options);
    const std::set<std::string> got = SelectedTerms(spec, r);
    ++out.seeds;
    if (got == s.terms) {
      ++out.hits;
    } else {
      out.misses += "seed " + std::to_string(seed) + ":";
      for (const auto& t : got) out.misses += " " + t;
      out.misses += "\n";
    }
  }
  return out;
}

}  // namespace mrd::test
