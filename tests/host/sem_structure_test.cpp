// Structure recovery on known polynomial NARX systems of the structure-selection literature,
// with equation-error (EE) and output-error (OE) noise: SEM must find the exact true
// structure on at least 19 of 20 noise seeds.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <set>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/sem.hpp"
#include "sem_test_util.hpp"

namespace mrd::host {
namespace {

// Candidates: y(k-1), y(k-2), u(k-1), u(k-2), products up to degree 3 with a constant:
// 34 non-constant terms + 1.
constexpr const char* kSpec = R"(
output = "y"
[[regressor]]
name = "y"
signal = "y"
transform = "identity"
powers = [1, 2, 3]
delays = [1, 2]
[[regressor]]
name = "u"
signal = "u"
transform = "identity"
powers = [1, 2, 3]
delays = [1, 2]
[limits]
max_factors = 3
max_degree = 3
constant = true
[cost]
weighting = "mse"
[algorithm]
max_iterations = 8
selection_tolerance_percent = 10.0
)";

enum class Noise { kEquation, kOutput };

// One system: next output from (y(k-1), y(k-2), u(k-1), u(k-2)) and its true terms.
struct System {
  std::function<double(double, double, double, double)> f;
  std::set<std::string> terms;
  double sigma;  // noise standard deviation
};

// Billings-style test system (e.g. Mao & Billings; Piroddi & Spinelli 2003):
// y(k) = 0.5 y(k-1) + 0.8 u(k-2) + u(k-1)^2 - 0.05 y(k-2)^2 + e(k).
System Polynomial() {
  return {[](double y1, double y2, double u1, double u2) {
            return 0.5 * y1 + 0.8 * u2 + u1 * u1 - 0.05 * y2 * y2;
          },
          {"y(k-1)", "u(k-2)", "u(k-1)^2", "y(k-2)^2"},
          0.1};
}

// Piroddi & Spinelli 2003, example 1 (the one that misleads prediction-error selection
// under output noise): y(k) = 0.75 y(k-2) + 0.25 u(k-1) - 0.2 y(k-2) u(k-1) + e(k).
System Piroddi() {
  return {
      [](double, double y2, double u1, double) { return 0.75 * y2 + 0.25 * u1 - 0.2 * y2 * u1; },
      {"y(k-2)", "u(k-1)", "y(k-2)*u(k-1)"},
      0.05};
}

DataSet Simulate(const System& s, Noise noise, std::uint64_t seed, std::size_t n) {
  test::Gauss g(seed);
  std::vector<double> u(n), w(n, 0.0), y(n, 0.0);
  for (auto& v : u) v = 2.0 * g.Uniform() - 1.0;
  for (std::size_t k = 2; k < n; ++k) {
    if (noise == Noise::kEquation) {
      y[k] = s.f(y[k - 1], y[k - 2], u[k - 1], u[k - 2]) + s.sigma * g();
    } else {
      w[k] = s.f(w[k - 1], w[k - 2], u[k - 1], u[k - 2]);
    }
  }
  if (noise == Noise::kOutput) {
    for (std::size_t k = 0; k < n; ++k) y[k] = w[k] + s.sigma * g();
  }
  return test::MakeDataSet("sim", {"u", "y"}, {u, y});
}

std::set<std::string> Structure(const SemSpec& spec, const SemResult& r) {
  std::set<std::string> out;
  for (const auto& it : r.iterations) {
    if (it.iteration == r.selected) {
      for (const auto& t : it.terms) out.insert(TermName(spec, t));
    }
  }
  return out;
}

int Recovered(const System& s, Noise noise, std::string* log) {
  const SemSpec spec = ParseSemSpec(kSpec, "structure.toml");
  int hits = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const std::vector<DataSet> id{Simulate(s, noise, 1000 + seed, 2000)};
    const std::vector<DataSet> val{Simulate(s, noise, 5000 + seed, 2000)};
    SemOptions o;
    o.threads = 2;
    const SemResult r = Identify(spec, id, val, o);
    const auto got = Structure(spec, r);
    if (got == s.terms) {
      ++hits;
    } else {
      std::string terms;
      for (const auto& t : got) terms += t + " ";
      *log += "seed " + std::to_string(seed) + ": " + terms + "\n";
    }
  }
  return hits;
}

TEST(SemStructureTest, PolynomialEquationError) {
  std::string log;
  const int hits = Recovered(Polynomial(), Noise::kEquation, &log);
  RecordProperty("hits", hits);
  EXPECT_GE(hits, 19) << log;
}

TEST(SemStructureTest, PolynomialOutputError) {
  std::string log;
  const int hits = Recovered(Polynomial(), Noise::kOutput, &log);
  RecordProperty("hits", hits);
  EXPECT_GE(hits, 19) << log;
}

TEST(SemStructureTest, PiroddiEquationError) {
  std::string log;
  const int hits = Recovered(Piroddi(), Noise::kEquation, &log);
  RecordProperty("hits", hits);
  EXPECT_GE(hits, 19) << log;
}

TEST(SemStructureTest, PiroddiOutputError) {
  std::string log;
  const int hits = Recovered(Piroddi(), Noise::kOutput, &log);
  RecordProperty("hits", hits);
  EXPECT_GE(hits, 19) << log;
}

TEST(SemStructureTest, CandidateCount) {
  const SemSpec spec = ParseSemSpec(kSpec, "structure.toml");
  EXPECT_EQ(GenerateCandidates(spec).size(), 35u);
}

}  // namespace
}  // namespace mrd::host
