// The SEM engine's speed work must not change a result: prepared reference runs
// (host/src/sem/estimate/replay.hpp) against the per-sample evaluation they replace, bit for bit,
// and the fast free run of a batch of candidate jobs independent of the jobs' order (the search
// sorts a sweep's jobs by their columns). Label sem.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/sem.hpp"
#include "mrd/host/sem_stress.hpp"
#include "sem/engine/engine.hpp"
#include "sem/estimate/replay.hpp"
#include "sem/internal.hpp"
#include "sem_test_util.hpp"

namespace mrd::host {
namespace {

// Output y(k-1) (identity, powers 1-2), inputs through abs_pow, tanh and sign at delays 0-1.
constexpr const char* kSpec = R"(output = "f"
[[regressor]]
name = "y"
signal = "f"
powers = [1, 2]
delays = [1]
[[regressor]]
name = "u1"
signal = "E"
powers = [1, 2, 3]
delays = [0]
[[regressor]]
name = "u2"
signal = "v"
transform = "abs_pow"
exponent = 0.2
powers = [1, 2, 5]
delays = [0, 1]
[[regressor]]
name = "w"
signal = "v"
transform = "tanh"
scale = 0.1
powers = [1, 3]
delays = [0, 1]
[[regressor]]
name = "u3"
signal = "v"
transform = "sign"
powers = [1]
delays = [0, 1]
[limits]
max_factors = 3
constant = false
[cost]
weighting = "relative"
floor = 0.1
)";

const DataSet& Data() {
  static const DataSet d = test::DamperData("identification", 6001);
  return d;
}

// SimulateCost's per-sample evaluation as it was before the records were prepared: every
// input transformed per call, every factor's power by repeated multiplication.
double Reference(const SemSpec& spec, const std::vector<ChannelInfo>& ch,
                 const std::vector<SemTerm>& terms, const std::vector<double>& coef,
                 const DataSet& data, std::vector<double>* ysim) {
  const auto signals = spec.Signals();
  std::vector<std::size_t> chan(spec.regressors.size());
  for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
    chan[r] = static_cast<std::size_t>(
        std::find(signals.begin(), signals.end(), spec.regressors[r].signal) - signals.begin());
  }
  const std::size_t n = data.rows(), d0 = static_cast<std::size_t>(spec.MaxDelay());
  std::vector<std::vector<double>> input(spec.regressors.size());
  for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
    if (chan[r] != 0) {
      input[r] = internal::TransformSignal(spec.regressors[r], data.Column(signals[chan[r]]),
                                           ch[chan[r]].scale);
    }
  }
  std::vector<double> y(n);
  for (std::size_t k = 0; k < n; ++k) y[k] = data.Column(signals[0])[k] / ch[0].scale;
  std::vector<double> yh(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(d0));
  yh.resize(n, 0.0);
  double cost = 0.0;
  bool bad = false;
  for (std::size_t k = d0; k < n; ++k) {
    double v = 0.0;
    for (std::size_t t = 0; t < terms.size(); ++t) {
      double tv = 1.0;
      for (const auto& f : terms[t].factors) {
        const auto& reg = spec.regressors[static_cast<std::size_t>(f.regressor)];
        const std::size_t kk = k - static_cast<std::size_t>(f.delay);
        const double x = chan[static_cast<std::size_t>(f.regressor)] == 0
                             ? ApplyTransform(reg.transform, reg.exponent, yh[kk])
                             : input[static_cast<std::size_t>(f.regressor)][kk];
        tv *= internal::Pow(x, f.power);
      }
      v += coef[t] * tv;
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
  if (bad || !std::isfinite(cost)) return std::numeric_limits<double>::infinity();
  return cost / static_cast<double>(n - d0);
}

std::vector<SemTerm> Terms(const SemSpec& spec, const std::vector<std::string>& names) {
  std::vector<SemTerm> t;
  for (const auto& s : names) t.push_back(ParseTerm(spec, s));
  return t;
}

TEST(SemReplayTest, PreparedRunEqualsThePerSampleEvaluationBitForBit) {
  const SemSpec spec = ParseSemSpec(kSpec, "replay.toml");
  const std::vector<DataSet> id{Data()};
  const auto ch = ComputeScales(spec, id);
  const internal::Replay replay(spec, ch, id[0]);
  const auto terms = Terms(spec, {"y(k-1)", "u1(k)*u2(k-1)^2*u3(k-1)", "y(k-1)^2*w(k)^3",
                                  "u2(k)^5*w(k-1)", "y(k-1)*u3(k)"});
  const std::vector<double> coef{0.55, 0.9, -0.03, 0.12, 0.2};
  std::vector<double> ys_ref, ys;
  const double ref = Reference(spec, ch, terms, coef, id[0], &ys_ref);
  ASSERT_TRUE(std::isfinite(ref));
  EXPECT_EQ(replay.Run(terms, coef, &ys), ref);
  EXPECT_EQ(ys, ys_ref);
  EXPECT_EQ(replay.Run(terms, coef), ref);  // without ysim
  EXPECT_EQ(SimulateCost(spec, ch, terms, coef, id[0]), ref);
}

TEST(SemReplayTest, DivergingRunCostsInfinityWithTheSameOutput) {
  const SemSpec spec = ParseSemSpec(kSpec, "replay.toml");
  const std::vector<DataSet> id{Data()};
  const auto ch = ComputeScales(spec, id);
  const internal::Replay replay(spec, ch, id[0]);
  const auto terms = Terms(spec, {"y(k-1)^2", "u1(k)"});
  const std::vector<double> coef{1.7, 1.0};
  std::vector<double> ys_ref, ys;
  EXPECT_TRUE(std::isinf(Reference(spec, ch, terms, coef, id[0], &ys_ref)));
  EXPECT_TRUE(std::isinf(replay.Run(terms, coef, &ys)));
  ASSERT_EQ(ys.size(), ys_ref.size());
  for (std::size_t k = 0; k < ys.size(); ++k) {  // NaN where the reference has NaN
    if (std::isnan(ys_ref[k])) {
      EXPECT_TRUE(std::isnan(ys[k])) << k;
    } else {
      EXPECT_EQ(ys[k], ys_ref[k]) << k;
    }
  }
}

// The fast free run of many candidate jobs gives every job the same cost, bit for bit, in any
// order of the jobs (lanes are independent).
TEST(SemReplayTest, CandidateJobsCostTheSameInAnyOrder) {
  const SemSpec spec = ParseSemSpec(kSpec, "replay.toml");
  const std::vector<DataSet> id{Data()};
  const auto ch = ComputeScales(spec, id);
  internal::Engine eng(spec, id, ch, 1);
  for (const SemTerm& t : GenerateCandidates(spec)) eng.AddCandidate(t);
  eng.PrepareCandidates();
  ASSERT_TRUE(eng.fast());
  ASSERT_GT(eng.num_candidates(), 100u);
  const std::vector<int> model{0, 5};
  std::vector<double> w;
  ASSERT_TRUE(eng.Solve(model, &w));
  std::vector<internal::Engine::Job> jobs;
  for (int c = 0; c < static_cast<int>(eng.num_candidates()); c += 3) {
    if (c == model[0] || c == model[1]) continue;
    internal::Engine::Job j;
    j.theta = w;
    j.extra = c;
    j.theta_extra = 0.01 * static_cast<double>(c % 7 - 3);
    jobs.push_back(j);
  }
  std::vector<internal::Engine::Job> rev(jobs.rbegin(), jobs.rend());
  const std::atomic<double> bound{std::numeric_limits<double>::infinity()};
  std::vector<double> scratch;
  eng.Simulate(model, jobs, bound, scratch);
  eng.Simulate(model, rev, bound, scratch);
  int finite = 0;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    const auto& a = jobs[i];
    const auto& b = rev[jobs.size() - 1 - i];
    EXPECT_EQ(a.diverged, b.diverged) << i;
    if (!a.diverged) {
      EXPECT_EQ(a.cost, b.cost) << i;
      ++finite;
    }
  }
  EXPECT_GT(finite, 10);
  // And each equals the job run alone.
  for (std::size_t i = 0; i < jobs.size(); i += 17) {
    internal::Engine::Job one = jobs[i];
    one.cost = 0.0;
    one.dead = one.diverged = false;
    eng.Simulate(model, std::span<internal::Engine::Job>(&one, 1), bound, scratch);
    EXPECT_EQ(one.diverged, jobs[i].diverged) << i;
    if (!one.diverged) {
      EXPECT_EQ(one.cost, jobs[i].cost) << i;
    }
  }
}

}  // namespace
}  // namespace mrd::host
