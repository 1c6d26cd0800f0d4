#pragma once
// Structure-recovery suite (issue 15): classic polynomial NARX systems of the
// structure-selection literature, simulated with equation-error (EE) or output-error (OE)
// noise, identified by SEM with the DEFAULT algorithm settings and no validation data. A seed
// counts as recovered when the selected model's terms are exactly the true ones. Used by
// sem_recovery_test.cpp (CTest label sem) and the sem_recovery table tool.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <exception>
#include <functional>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/sem.hpp"
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

// kEquation: y(k) = f(...) + e(k); kOutput: y(k) = w(k) + e(k), w(k) = f(w...); kColoured:
// y(k) = f(...) + the system's own noise model (RecoverySystem::coloured) of white e.
enum class Noise { kEquation, kOutput, kColoured };

// Input signal of a system: uniform on [-amplitude, amplitude], or Gaussian with standard
// deviation `amplitude` (the published setups differ).
enum class Input { kUniform, kGaussian };

// One system: next noise-free output from (y(k-1), y(k-2), u(k-1), u(k-2)), its true terms,
// the noise standard deviation, the input, and for kColoured noise the equation noise
// v(k) = coloured(e(k), e(k-1), e(k-2), u(k-1)) of white Gaussian e (standard deviation sigma).
struct RecoverySystem {
  std::string name;
  std::function<double(double, double, double, double)> f;
  std::set<std::string> terms;
  double sigma = 0.0;
  Input input = Input::kUniform;
  double amplitude = 1.0;
  std::function<double(double, double, double, double)> coloured;  // empty: white only
  std::vector<Noise> noises{Noise::kEquation, Noise::kOutput};     // cases of the table tool
};

inline const char* NoiseName(Noise n) {
  return n == Noise::kEquation ? "EE" : n == Noise::kOutput ? "OE" : "MA";
}

inline Noise NoiseNamed(const std::string& s) {
  return s == "OE" ? Noise::kOutput : s == "MA" ? Noise::kColoured : Noise::kEquation;
}

inline std::vector<RecoverySystem> RecoverySystems() {
  return {
      // Billings-style test system (e.g. Mao & Billings 1997; Piroddi & Spinelli 2003).
      {"billings",
       [](double y1, double y2, double u1, double u2) {
         return 0.5 * y1 + 0.8 * u2 + u1 * u1 - 0.05 * y2 * y2;
       },
       {"y(k-1)", "u(k-2)", "u(k-1)^2", "y(k-2)^2"},
       0.1,
       Input::kUniform,
       1.0,
       {},
       {Noise::kEquation, Noise::kOutput}},
      // Piroddi & Spinelli 2003, example 1 (misleads prediction-error selection under OE noise).
      {"piroddi",
       [](double, double y2, double u1, double) { return 0.75 * y2 + 0.25 * u1 - 0.2 * y2 * u1; },
       {"y(k-2)", "u(k-1)", "y(k-2)*u(k-1)"},
       0.05,
       Input::kUniform,
       1.0,
       {},
       {Noise::kEquation, Noise::kOutput}},
      // Wei & Billings 2008 (integrated forward orthogonal search), example 1.
      {"wei",
       [](double y1, double y2, double u1, double u2) {
         return -0.605 * y1 - 0.163 * y2 * y2 + 0.588 * u1 - 0.24 * u2;
       },
       {"y(k-1)", "y(k-2)^2", "u(k-1)", "u(k-2)"},
       0.04,
       Input::kUniform,
       1.0,
       {},
       {Noise::kEquation, Noise::kOutput}},
      // Lightly damped linear second order: poles 0.75 +- 0.58i (radius 0.949, damping
      // ratio 0.08); the case where greedy best improvement locks in on a product term.
      {"linear2",
       [](double y1, double y2, double u1, double u2) {
         return 1.5 * y1 - 0.9 * y2 + 0.5 * u1 + 0.3 * u2;
       },
       {"y(k-1)", "y(k-2)", "u(k-1)", "u(k-2)"},
       0.1,
       Input::kUniform,
       1.0,
       {},
       {Noise::kEquation, Noise::kOutput}},
      // Published benchmark systems with a cubic output term or coloured equation noise, as
      // the MetaMSS chapter of the SysIdentPy book (Lacerda Junior, Martins, Nepomuceno,
      // "Meta-model structure selection", arXiv:2109.09917; text in wilsonrljr/sysidentpy,
      // book chapter on MetaMSS, eq. 57) states them, inputs and noise levels as published;
      // S1-S4 and S6 were also used by Bianchi, Falsone, Prandini & Piroddi (IJSS 2017),
      // S6 is Piroddi & Spinelli 2003's example with delay 2 on the input. Published record
      // length: 500 samples, lags 4; here the suite's 35 candidates (lags 2, degree 3).
      // S1: linear, lightly damped (poles -0.85 +- 0.28i, radius 0.894); x ~ U(-2, 2),
      // e ~ N(0, 0.01^2).
      {"metamss_s1",
       [](double y1, double y2, double u1, double u2) {
         return -1.7 * y1 - 0.8 * y2 + u1 + 0.81 * u2;
       },
       {"y(k-1)", "y(k-2)", "u(k-1)", "u(k-2)"},
       0.01,
       Input::kUniform,
       2.0,
       {},
       {Noise::kEquation}},
      // S2: cubic input term; x ~ N(0, 0.3^2), e ~ N(0, 0.01^2).
      {"metamss_s2",
       [](double y1, double, double u1, double) {
         return 0.8 * y1 + 0.4 * u1 + 0.4 * u1 * u1 + 0.4 * u1 * u1 * u1;
       },
       {"y(k-1)", "u(k-1)", "u(k-1)^2", "u(k-1)^3"},
       0.01,
       Input::kGaussian,
       0.3,
       {},
       {Noise::kEquation}},
      // S3: cubic output term; x ~ U(-1, 1), e ~ N(0, 0.01^2). Not stable for every input
      // realisation (about 7 % of records of 700 samples diverge): RecoveryData redraws.
      {"metamss_s3",
       [](double y1, double y2, double u1, double u2) {
         return 0.2 * y1 * y1 * y1 + 0.7 * y1 * u1 + 0.6 * u2 * u2 - 0.7 * y2 * u2 * u2 - 0.5 * y2;
       },
       {"y(k-1)^3", "y(k-1)*u(k-1)", "u(k-2)^2", "y(k-2)*u(k-2)^2", "y(k-2)"},
       0.01,
       Input::kUniform,
       1.0,
       {},
       {Noise::kEquation}},
      // S5: S4's process with NARMAX noise e(k) + 0.2 e(k-1) - 0.3 x(k-1) e(k-2) (a moving
      // average, one term input-dependent); x ~ U(-1, 1), e ~ N(0, 0.02^2). The NARX terms
      // are the structure to recover (the noise terms are no candidates).
      {"metamss_s5",
       [](double y1, double y2, double u1, double u2) {
         return 0.7 * y1 * u1 - 0.5 * y2 + 0.6 * u2 * u2 - 0.7 * y2 * u2 * u2;
       },
       {"y(k-1)*u(k-1)", "y(k-2)", "u(k-2)^2", "y(k-2)*u(k-2)^2"},
       0.02,
       Input::kUniform,
       1.0,
       [](double e0, double e1, double e2, double u1) { return e0 + 0.2 * e1 - 0.3 * u1 * e2; },
       {Noise::kColoured}},
      // S4: S3 without the cubic term; x ~ U(-1, 1), e ~ N(0, 0.04^2).
      {"metamss_s4",
       [](double y1, double y2, double u1, double u2) {
         return 0.7 * y1 * u1 - 0.5 * y2 + 0.6 * u2 * u2 - 0.7 * y2 * u2 * u2;
       },
       {"y(k-1)*u(k-1)", "y(k-2)", "u(k-2)^2", "y(k-2)*u(k-2)^2"},
       0.04,
       Input::kUniform,
       1.0,
       {},
       {Noise::kEquation}},
      // S6: Piroddi & Spinelli's example with the input at delay 2; x ~ N(0, 0.25^2),
      // e ~ N(0, 0.02^2).
      {"metamss_s6",
       [](double, double y2, double, double u2) { return 0.75 * y2 + 0.25 * u2 - 0.2 * y2 * u2; },
       {"y(k-2)", "u(k-2)", "y(k-2)*u(k-2)"},
       0.02,
       Input::kGaussian,
       0.25,
       {},
       {Noise::kEquation}},
      // SysIdentPy's own test system (sysidentpy/utils/generate_data.py, get_siso_data, the
      // data of its MetaMSS examples): y(k) = 0.2 y(k-1) + 0.1 y(k-1) x(k-1) + 0.9 x(k-2) +
      // e(k), colored_noise: e(k) = nu(k) + 0.8 nu(k-1) (MA(1)); x ~ U(-1, 1); nu ~ N(0, 0.1^2)
      // (the MetaMSS example's sigma; the function's default is 0.05).
      {"sysidentpy_ma",
       [](double y1, double, double u1, double u2) { return 0.2 * y1 + 0.1 * y1 * u1 + 0.9 * u2; },
       {"y(k-1)", "y(k-1)*u(k-1)", "u(k-2)"},
       0.1,
       Input::kUniform,
       1.0,
       [](double e0, double e1, double, double) { return e0 + 0.8 * e1; },
       {Noise::kColoured}},
  };
}

// n samples of a system (after 200 samples of warm-up), noise seeded by seed. A record whose
// output leaves |y| <= 1e3 (metamss_s3 is not stable for every input) is drawn again from the
// same generator, so every seed gives a bounded record of the published system.
inline host::DataSet RecoveryData(const RecoverySystem& s, Noise noise, std::uint64_t seed,
                                  std::size_t n) {
  Gauss g(seed);
  const std::size_t warm = 200, total = n + warm;
  std::vector<double> u(total), w(total, 0.0), y(total, 0.0), e(total, 0.0);
  for (bool bounded = false; !bounded;) {
    for (auto& v : u) {
      v = s.input == Input::kUniform ? s.amplitude * (2.0 * g.Uniform() - 1.0) : s.amplitude * g();
    }
    std::fill(w.begin(), w.end(), 0.0);
    std::fill(y.begin(), y.end(), 0.0);
    bounded = true;
    for (std::size_t k = 2; k < total && bounded; ++k) {
      if (noise == Noise::kEquation) {
        y[k] = s.f(y[k - 1], y[k - 2], u[k - 1], u[k - 2]) + s.sigma * g();
      } else if (noise == Noise::kColoured) {
        e[k] = s.sigma * g();
        y[k] = s.f(y[k - 1], y[k - 2], u[k - 1], u[k - 2]) +
               (s.coloured ? s.coloured(e[k], e[k - 1], e[k - 2], u[k - 1]) : e[k]);
      } else {
        w[k] = s.f(w[k - 1], w[k - 2], u[k - 1], u[k - 2]);
      }
      bounded = std::abs(y[k]) <= 1e3 && std::abs(w[k]) <= 1e3;
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
// validation data; counts exact recoveries of the selected model. The seeds are shared among
// `workers` threads (0: one per core), each identifying whole seeds with options.threads
// threads: every seed's result is the same as in a serial run, and the count and the misses
// (in seed order) are too.
inline RecoveryCount CountRecovered(const RecoverySystem& s, Noise noise, std::size_t n, int seeds,
                                    const host::SemOptions& options = {},
                                    const std::string& spec_text = kRecoverySpec,
                                    unsigned workers = 1) {
  const host::SemSpec spec = host::ParseSemSpec(spec_text, "recovery.toml");
  if (workers == 0) workers = std::max(1U, std::thread::hardware_concurrency());
  workers = std::min(workers, static_cast<unsigned>(std::max(seeds, 1)));
  std::vector<std::set<std::string>> selected(static_cast<std::size_t>(std::max(seeds, 0)));
  std::vector<std::exception_ptr> failed(workers);
  std::atomic<int> next{1};
  const auto work = [&](unsigned w) {
    try {
      for (int seed = next++; seed <= seeds; seed = next++) {
        const std::vector<host::DataSet> id{SuiteData(s, noise, n, seed)};
        selected[static_cast<std::size_t>(seed - 1)] =
            SelectedTerms(spec, host::Identify(spec, id, {}, options));
      }
    } catch (...) {
      failed[w] = std::current_exception();
      next = seeds + 1;  // the others stop after their seed
    }
  };
  std::vector<std::thread> pool;
  for (unsigned w = 1; w < workers; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  for (const auto& e : failed) {
    if (e) std::rethrow_exception(e);
  }
  RecoveryCount out;
  for (int seed = 1; seed <= seeds; ++seed) {
    const std::set<std::string>& got = selected[static_cast<std::size_t>(seed - 1)];
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
