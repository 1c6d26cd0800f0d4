#include "mrd/host/sem.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <map>

#include "mrd/host/input_error.hpp"
#include "mrd/host/sem_stress.hpp"
#include "sem_engine.hpp"
#include "sem_evaluator.hpp"
#include "sem_internal.hpp"
#include "sem_replay.hpp"
#include "sem_search.hpp"

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

using internal::Engine, internal::Search, internal::Trial, internal::kInf;

constexpr int kMaxExchanges = 8;           // exchange passes per major iteration
constexpr std::size_t kExchangePool = 64;  // candidates (best one-step rank) tried per term
constexpr double kExchangeGain = 1e-9;     // relative J decrease an exchange must bring
constexpr std::size_t kScorePool = 8;      // candidates per term for exchanges under the score
constexpr int kMaxScoreMoves = 16;         // moves of the pick under the score

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
                       fmt::format("{} rows: too short for the spec's largest delay {}", d.rows(),
                                   spec.MaxDelay()));
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
  return internal::Replay(spec, channels, data).Run(terms, coefficients, ysim);
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
    fmt::print(stderr,
               "warning: signal '{}' is constant ({}) in the identification data; its "
               "terms cannot be told from the constant\n",
               s, lo);
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
  // Stress and validation records prepared once for their many reference runs.
  std::vector<internal::Replay> stress_runs, validation_runs;
  for (const DataSet& d : stress) stress_runs.emplace_back(spec, res.channels, d);
  for (const DataSet& d : validation) validation_runs.emplace_back(spec, res.channels, d);
  auto stress_of = [&](const std::vector<int>& terms, const std::vector<double>& th) {
    std::vector<SemTerm> t;
    for (int c : terms) t.push_back(eng.cand(c).term);
    return internal::CheckStressPrepared(spec, t, th, stress_runs);
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
    for (const auto& v : validation_runs) vj.push_back(v.Run(terms, coefficients));
    return vj;
  };
  // The stress check, validation and refinement of a recorded iteration do not feed the search:
  // with two or more threads they run beside the search of the next iteration (one iteration at
  // a time, so the iterations are completed, reported and stored in order). The results are
  // the same either way.
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
    // Stress check, validation runs and output-error refinement (kept when it lowers J, passes
    // the stress check as the least squares did, and, with validation data, makes no
    // validation set's J worse): beside the next search step with two or more threads.
    auto complete = [&, it = std::move(it), terms = model]() mutable {
      it.stress = stress_of(terms, it.coefficients);
      it.validation_j = validate(it.terms, it.coefficients);
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
    if (o.threads > 1) {
      refining = std::async(std::launch::async, std::move(complete));
    } else {
      complete();
    }
  };
  // Pruning: drop the term whose removal gives the lowest J while that J is below j_prev.
  auto prune = [&](double j_prev) {
    while (model.size() > 1) {
      std::size_t drop = 0;
      std::vector<double> best_theta;
      const double best = search.BestDrop(model, j_prev, &drop, &best_theta);
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
      const Trial tr =
          search.TryAdd(model, theta, strategy == Strategy::kFirst,
                        j_prev * (1.0 - threshold / 100.0), &rejected, accept, &stress_rejected);
      if (tr.cand < 0) {  // nothing admissible
        res.exhausted_rejected = rejected;
        break;
      }
      model.push_back(tr.cand);
      j = search.Cost(model, &theta);
      prune(j_prev);
      // Exchange: replace one term by a candidate while that lowers J, then prune again.
      const auto tx = std::chrono::steady_clock::now();
      for (int pass = 0; pass < exchanges && exchange(&rejected, &stress_rejected); ++pass) {
        prune(j_prev);
      }
      if (exchanges > 0) {
        res.exchange_s +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - tx).count();
      }
      record(iteration, rejected, stress_rejected);
    }
    finish_recorded();
  };
  // Local search under the selection's score (cross-validated selection only). The search
  // prunes a term only when J falls without it, so a path can start with a spurious term (the
  // one-step start) that it never drops; and it compares structures by the least squares' J,
  // which output-error noise biases towards a close relative of a true term (y(k-2)^3 for
  // y(k-2)^2). Either way the truth is then on no path. Moves from the pick: drop a term
  // (drop_terms), or exchange one for a candidate of the kScorePool best by one-step rank
  // (score_exchange). Each structure is fitted (least squares, refined) and scored on the
  // selection's folds; the best move is taken while the score falls (a local minimum of the
  // score). The result is a further iteration, selected, with the moves in the rule.
  auto improve_by_score = [&](const internal::SelectionCriterion& criterion) {
    if (!(spec.drop_terms || spec.score_exchange) || !criterion || res.selected < 0) return;
    auto sel = std::find_if(res.iterations.begin(), res.iterations.end(),
                            [&](const SemIteration& it) { return it.iteration == res.selected; });
    if (sel == res.iterations.end() || sel->cv_j.empty()) return;
    SemIteration cur = *sel;
    std::vector<int> cur_model;
    for (const SemTerm& t : cur.terms) {
      const auto k = by_key.find(TermKey(spec, t));
      if (k == by_key.end()) return;
      cur_model.push_back(k->second);
    }
    const auto name = [&](int c) { return TermName(spec, eng.cand(c).term); };
    double cur_score = criterion.Score(cur.cv_j, cur_model.size());
    std::vector<std::string> moves;
    for (int step = 0; step < kMaxScoreMoves; ++step) {
      struct Move {
        std::vector<int> model;
        std::vector<double> theta;
        std::vector<double> cv;
        double j = kInf;
        double score = kInf;
        std::size_t out = 0;  // index of the dropped or exchanged term in cur_model
        int in = -1;          // the candidate exchanged in (-1: a drop)
      };
      std::vector<Move> mv;
      for (std::size_t i = 0; i < cur_model.size(); ++i) {  // least squares (the engine's cache)
        std::vector<int> reduced = cur_model;
        reduced.erase(reduced.begin() + static_cast<std::ptrdiff_t>(i));
        std::vector<double> th;
        const bool solved = eng.Solve(reduced, &th);
        if (spec.drop_terms && !reduced.empty() && solved) {
          mv.push_back({reduced, th, {}, kInf, kInf, i, -1});
        }
        if (!spec.score_exchange || !solved) continue;
        for (Trial& tr : search.Ranked(reduced, th, kScorePool)) {  // theta: reduced, then c
          if (tr.cand == cur_model[i]) continue;
          Move x{reduced, std::move(tr.theta), {}, kInf, kInf, i, tr.cand};
          x.model.push_back(tr.cand);
          mv.push_back(std::move(x));
        }
      }
      internal::ParallelFor(mv.size(), o.threads, [&](std::size_t i, int) {
        Move& d = mv[i];
        std::vector<SemTerm> terms;
        for (int c : d.model) terms.push_back(eng.cand(c).term);
        d.cv = criterion.fold_costs(terms, &d.theta, &d.j);
        d.score = criterion.Score(d.cv, d.model.size());
      });
      const Move* best = nullptr;
      StressVerdict best_stress;
      for (const Move& d : mv) {
        if (!(d.score < (best != nullptr ? best->score : cur_score)) || !std::isfinite(d.j)) {
          continue;
        }
        const StressVerdict v = stress_of(d.model, d.theta);  // unchecked without [stress]
        if (!stress.empty() && !v.pass) continue;
        best = &d;
        best_stress = v;
      }
      if (best == nullptr) break;
      moves.push_back(best->in < 0 ? fmt::format("dropped {}", name(cur_model[best->out]))
                                   : fmt::format("exchanged {} for {}", name(cur_model[best->out]),
                                                 name(best->in)));
      cur_model = best->model;
      cur.terms.clear();
      for (int c : cur_model) cur.terms.push_back(eng.cand(c).term);
      cur.coefficients = best->theta;
      cur.j = best->j;
      cur.cv_j = best->cv;
      cur.stress = best_stress;
      cur_score = best->score;
    }
    if (moves.empty()) return;
    cur.iteration = res.iterations.back().iteration + 1;
    cur.rejected = cur.stress_rejected = 0;
    cur.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (o.progress) o.progress(cur);
    res.selected = cur.iteration;
    res.iterations.push_back(std::move(cur));
    std::string list;
    for (const std::string& m : moves) {
      if (!list.empty()) list += ", ";
      list += m;
    }
    res.selection_rule +=
        fmt::format("; then the pick changed while that lowers the score (iteration {}): {}",
                    res.selected, list);
  };
  const std::vector<int> initial_model = model;
  run_path();
  res.path_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() -
               res.exchange_s;
  // Second start: the structure the one-step (prediction-error) criterion selects by forward
  // regression, stopped by BIC on its one-step SSE, then pruned by J. Escapes the lock-in of
  // the greedy search when a single added term cannot show the gain of a pair (a lightly
  // damped resonance needs y(k-1) and y(k-2) together).
  if (initial.empty() && spec.one_step_start) {
    std::vector<SemIteration> first_path = std::move(res.iterations);
    res.iterations.clear();
    const auto t2 = std::chrono::steady_clock::now();
    // Bound: the start has at most as many terms as the largest model of the first path, so
    // its path costs no more per step (a 40-term start on noise-free damper data cost 20x).
    std::size_t cap = 1;
    for (const SemIteration& it : first_path) cap = std::max(cap, it.terms.size());
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
    while (model.size() + 1 <= max_params && model.size() < cap) {
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
    res.second_start_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t2).count();
    res.second_start_terms = start.size();
    std::vector<SemIteration> second_path = std::move(res.iterations);
    // Select over both paths (second path renumbered after the first), keep the picked one.
    const int offset = static_cast<int>(first_path.size());
    res.iterations = std::move(first_path);
    for (SemIteration it : second_path) {
      it.iteration += offset;
      res.iterations.push_back(std::move(it));
    }
    internal::SelectionCriterion criterion;
    internal::SelectModel(spec, identification, o.threads, &res, &criterion);
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
    improve_by_score(criterion);
  } else {
    internal::SelectionCriterion criterion;
    internal::SelectModel(spec, identification, o.threads, &res, &criterion);
    improve_by_score(criterion);
  }
  if (res.selected < 0) {
    throw InputError(spec.path, spec.stress.line,
                     "no iteration passes the stress check ([stress]): nothing to select");
  }
  return res;
}

}  // namespace mrd::host
