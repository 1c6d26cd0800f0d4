// SearchPath (search_path.hpp): set-up, the run, the second start and the selection.
#include "sem/search/search_path.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "mrd/host/input_error.hpp"

namespace mrd::host::internal {

SearchPath::SearchPath(const SemSpec& spec, std::span<const DataSet> identification,
                       std::span<const DataSet> validation, const SemOptions& o)
    : spec_(spec),
      identification_(identification),
      validation_(validation),
      o_(o),
      t0_(std::chrono::steady_clock::now()),
      strategy_(o.strategy.value_or(spec.strategy)),
      threshold_(o.threshold_percent.value_or(spec.threshold_percent)),
      max_it_(o.max_iterations.value_or(spec.max_iterations)),
      target_(o.target_j.value_or(spec.target_j)),
      initial_(o.initial ? *o.initial : spec.initial) {
  if (identification.empty()) throw InputError("", 0, "no identification data");
  CheckData(spec, identification);
  CheckData(spec, validation);
  res_.channels = ComputeScales(spec, identification);
  RecordEnvelope(identification, &res_.channels);
  stress_ = BuildStressData(spec, identification);
  rest_ = BuildRestData(spec, identification);
  CheckSettings();
  BuildCandidates();
  search_.emplace(*eng_, o.threads);
  PrepareRuns();
  if (!spec.monotone_in.empty()) gate_.emplace(spec, res_.channels, identification);
  j_ = search_->Cost(model_, &theta_);
}

void SearchPath::CheckSettings() {
  if (!std::isfinite(target_)) {
    throw InputError(o_.target_j ? "" : spec_.path, 0,
                     fmt::format("target J {} is not a finite number", target_));
  }
  if (!std::isfinite(threshold_)) {
    throw InputError("", 0, fmt::format("threshold {} is not a finite number", threshold_));
  }
  CheckSamples();
  WarnConstantSignals();
}

// Enough data for the parameters.
void SearchPath::CheckSamples() {
  for (const auto& d : identification_) {
    samples_ += d.rows() - static_cast<std::size_t>(spec_.MaxDelay());
  }
  max_params_ = samples_ / kMinSamplesPerParameter;
  if (max_params_ == 0) {
    throw InputError(identification_.front().path, 0,
                     fmt::format("{} scored samples: identification needs at least {} samples "
                                 "per parameter",
                                 samples_, kMinSamplesPerParameter));
  }
}

// An output that varies (else InputError); a constant input only warns.
void SearchPath::WarnConstantSignals() const {
  for (const std::string& s : spec_.Signals()) {
    double lo = kInf, hi = -kInf;
    for (const auto& d : identification_) {
      for (const double v : d.Column(s)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
    if (lo < hi) continue;
    if (s == spec_.output) {
      throw InputError(identification_.front().path, 0,
                       fmt::format("output '{}' is constant ({}) in the identification data: "
                                   "nothing to identify",
                                   s, lo));
    }
    fmt::print(stderr,
               "warning: signal '{}' is constant ({}) in the identification data; its "
               "terms cannot be told from the constant\n",
               s, lo);
  }
}

// The engine's candidates (at most max_candidates) and the initial model, which may add terms
// the spec does not generate.
void SearchPath::BuildCandidates() {
  SemSpec limited = spec_;
  if (o_.max_candidates) limited.max_candidates = *o_.max_candidates;
  eng_.emplace(spec_, identification_, res_.channels, o_.threads);
  for (const SemTerm& t : GenerateCandidates(limited)) {
    by_key_.emplace(TermKey(spec_, t), eng_->AddCandidate(t));
  }
  res_.num_candidates = eng_->num_candidates();
  res_.fast_path = eng_->fast();
  for (const auto& text : initial_) {
    const SemTerm t = ParseTerm(spec_, text, o_.initial ? "" : spec_.path, 0);
    const std::string key = TermKey(spec_, t);
    auto it = by_key_.find(key);
    const int idx = it != by_key_.end() ? it->second : eng_->AddCandidate(t);
    by_key_.emplace(key, idx);
    if (std::find(model_.begin(), model_.end(), idx) == model_.end()) model_.push_back(idx);
  }
  if (model_.size() > max_params_) {
    throw InputError("", 0,
                     fmt::format("initial structure has {} terms; {} scored samples allow at "
                                 "most {} ({} per parameter)",
                                 model_.size(), samples_, max_params_, kMinSamplesPerParameter));
  }
  eng_->PrepareCandidates();
}

void SearchPath::PrepareRuns() {
  for (const DataSet& d : stress_) stress_runs_.emplace_back(spec_, res_.channels, d);
  for (const DataSet& d : rest_) rest_runs_.emplace_back(spec_, res_.channels, d);
  for (const DataSet& d : validation_) validation_runs_.emplace_back(spec_, res_.channels, d);
  if (spec_.refine) {
    for (const DataSet& d : identification_) evaluators_.emplace_back(spec_, res_.channels, d);
  }
}

double SearchPath::Elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
}

std::vector<SemTerm> SearchPath::Terms(const std::vector<int>& model) const {
  std::vector<SemTerm> t;
  for (int c : model) t.push_back(eng_->cand(c).term);
  return t;
}

StressVerdict SearchPath::SearchStressOf(const std::vector<int>& terms,
                                         const std::vector<double>& th) const {
  return CheckStressPrepared(spec_, Terms(terms), th, stress_runs_);
}

bool SearchPath::SearchStressPasses(const std::vector<int>& terms,
                                    const std::vector<double>& th) const {
  return StressPassesPrepared(spec_, Terms(terms), th, stress_runs_);
}

StressVerdict SearchPath::StressOf(const std::vector<int>& terms,
                                   const std::vector<double>& th) const {
  const StressVerdict a = SearchStressOf(terms, th);
  if (!a.pass || rest_runs_.empty()) return a;
  StressVerdict r = CheckStressPrepared(spec_, Terms(terms), th, rest_runs_);
  r.peak = std::max(r.peak, a.peak);
  return r;
}

MonotoneVerdict SearchPath::MonotoneOf(const std::vector<int>& terms,
                                       const std::vector<double>& th) const {
  return gate_ ? gate_->Check(Terms(terms), th) : MonotoneVerdict{};
}

bool SearchPath::MonotonePasses(const std::vector<int>& terms,
                                const std::vector<double>& th) const {
  return !gate_ || gate_->Passes(Terms(terms), th);
}

Search::Accept SearchPath::AcceptFor(const std::vector<int>& base) const {
  if (stress_.empty() && !gate_) return {};
  // Only reads: TryAdd asks it on several threads at once.
  return [this, base](int cand, const std::vector<double>& th) {
    std::vector<int> terms = base;
    terms.push_back(cand);
    if (!MonotonePasses(terms, th)) return Search::Verdict::kMonotone;
    if (!stress_.empty() && !SearchStressPasses(terms, th)) return Search::Verdict::kStress;
    return Search::Verdict::kAccept;
  };
}

Search::Screen SearchPath::ScreenFor(const std::vector<int>& base) const {
  if (!gate_) return {};
  return [this, base_terms = Terms(base)](int cand, const std::vector<double>& th) {
    std::vector<SemTerm> terms = base_terms;
    terms.push_back(eng_->cand(cand).term);
    return gate_->PassesScreen(terms, th);
  };
}

std::vector<double> SearchPath::Validate(const std::vector<SemTerm>& terms,
                                         const std::vector<double>& coefficients) const {
  std::vector<double> vj;
  for (const auto& v : validation_runs_) vj.push_back(v.Run(terms, coefficients));
  return vj;
}

SemResult SearchPath::Run() {
  RunPath();
  res_.path_s = Elapsed() - res_.exchange_s;
  SelectionCriterion criterion;
  if (initial_.empty() && spec_.one_step_start) {
    SecondStart(&criterion);
  } else {
    SelectModel(spec_, identification_, o_.threads, &res_, &criterion);
  }
  LocalSearch(criterion);
  if (res_.selected < 0) {
    const bool stress = !stress_.empty();
    throw InputError(spec_.path, stress ? spec_.stress.line : spec_.monotone_line,
                     fmt::format("no iteration passes {}: nothing to select",
                                 stress && gate_ ? "the stress check ([stress]) and monotone_in"
                                 : stress        ? "the stress check ([stress])"
                                                 : "monotone_in"));
  }
  return std::move(res_);
}

// The structure the one-step (prediction-error) criterion selects by forward regression,
// stopped by BIC on its one-step SSE, at most as many terms as the largest model of the first
// path (so its path costs no more per step: a 40-term start on noise-free damper data cost
// 20x), then pruned by J. Returns its size; the model is the start.
std::size_t SearchPath::OneStepStart() {
  std::size_t cap = 1;
  for (const SemIteration& it : res_.iterations) cap = std::max(cap, it.terms.size());
  double yty = 0.0;
  for (const auto& d : identification_) {
    const auto& y = d.Column(spec_.output);
    for (std::size_t k = static_cast<std::size_t>(spec_.MaxDelay()); k < y.size(); ++k) {
      yty += (y[k] / res_.channels[0].scale) * (y[k] / res_.channels[0].scale);
    }
  }
  const double n = static_cast<double>(samples_);
  model_.clear();
  theta_.clear();
  double sse = yty, bic = n * std::log(std::max(yty, 1e-300) / n);
  while (model_.size() + 1 <= max_params_ && model_.size() < cap) {
    int rej = 0;
    const Trial tr = search_->TryAdd(model_, theta_, false, -kInf, &rej, AcceptFor(model_), nullptr,
                                     1, kInf, ScreenFor(model_));
    if (tr.cand < 0) break;
    const double sse_new = sse - tr.rank;
    const double bic_new = n * std::log(std::max(sse_new, 1e-300) / n) +
                           static_cast<double>(model_.size() + 1) * std::log(n);
    if (!(bic_new < bic)) break;
    model_.push_back(tr.cand);
    theta_ = tr.theta;
    sse = sse_new;
    bic = bic_new;
  }
  j_ = search_->Cost(model_, &theta_);
  for (double before = kInf; j_ < before;) {
    before = j_;
    Prune(before);
  }
  return model_.size();
}

// Second start: a second path from OneStepStart. Escapes the lock-in of the greedy search when
// a single added term cannot show the gain of a pair (a lightly damped resonance needs y(k-1)
// and y(k-2) together). Selects over both paths (the second renumbered after the first) and
// keeps the picked path (with its CV costs).
void SearchPath::SecondStart(SelectionCriterion* criterion) {
  const auto t2 = std::chrono::steady_clock::now();
  const std::size_t start = OneStepStart();
  std::vector<SemIteration> first_path = std::move(res_.iterations);
  res_.iterations.clear();
  RunPath();
  res_.second_start_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t2).count();
  res_.second_start_terms = start;
  std::vector<SemIteration> second_path = std::move(res_.iterations);
  const int offset = static_cast<int>(first_path.size());
  res_.iterations = std::move(first_path);
  for (SemIteration it : second_path) {
    it.iteration += offset;
    res_.iterations.push_back(std::move(it));
  }
  SelectModel(spec_, identification_, o_.threads, &res_, criterion);
  const bool second = res_.selected >= offset;
  if (second) {
    res_.iterations.erase(res_.iterations.begin(), res_.iterations.begin() + offset);
    for (SemIteration& it : res_.iterations) it.iteration -= offset;
    res_.selected -= offset;
  } else {
    res_.iterations.resize(static_cast<std::size_t>(offset));
  }
  res_.selection_rule += fmt::format(
      "; over two search starts, kept: {} (the {}-term one-step forward-regression start {})",
      second ? "the one-step start" : "the initial structure", start, second ? "won" : "lost");
}

}  // namespace mrd::host::internal
