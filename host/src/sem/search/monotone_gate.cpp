// MonotoneGate (monotone_gate.hpp): the search's invertibility check on prepared states.
#include "sem/search/monotone_gate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>

#include "mrd/host/input_error.hpp"
#include "mrd/host/invertibility.hpp"

namespace mrd::host::internal {
namespace {

const ChannelInfo& Channel(const std::vector<ChannelInfo>& ch, const std::string& name) {
  return *std::find_if(ch.begin(), ch.end(), [&](const ChannelInfo& c) { return c.name == name; });
}

int Sign(double v) { return v > 0.0 ? 1 : (v < 0.0 ? -1 : 0); }

}  // namespace

MonotoneGate::MonotoneGate(const SemSpec& spec, const std::vector<ChannelInfo>& channels,
                           std::span<const DataSet> identification)
    : spec_(spec), data_(identification) {
  const auto refuse = [&](const std::string& why) {
    return InputError(spec.path, spec.monotone_line, fmt::format("monotone_in: {}", why));
  };
  const std::vector<std::string> signals = spec.Signals();
  if (signals.size() > kMaxChannels) {
    throw refuse(fmt::format("the spec has {} signals; a model holds at most {}", signals.size(),
                             kMaxChannels));
  }
  if (spec.regressors.size() > kMaxRegressors) {
    throw refuse(fmt::format("the spec has {} regressors; a model holds at most {}",
                             spec.regressors.size(), kMaxRegressors));
  }
  model_.num_channels = static_cast<std::uint8_t>(signals.size());
  model_.output_channel = 0;
  for (std::size_t c = 0; c < signals.size(); ++c) {
    if (signals[c].size() > kMaxNameLength) {
      throw refuse(
          fmt::format("signal name '{}' is longer than {} characters", signals[c], kMaxNameLength));
    }
    std::memcpy(model_.channel_names[c].data(), signals[c].c_str(), signals[c].size() + 1);
    const ChannelInfo& ci = Channel(channels, signals[c]);
    model_.scales[c] = {ci.offset, ci.scale};
  }
  input_ = static_cast<std::size_t>(model_.ChannelIndex(spec.monotone_in.c_str()));
  model_.num_regressors = static_cast<std::uint8_t>(spec.regressors.size());
  for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
    const ElementaryRegressor& er = spec.regressors[r];
    const auto c = static_cast<std::uint8_t>(model_.ChannelIndex(er.signal.c_str()));
    model_.regressors[r] = {c, er.transform, er.exponent};
    if (c == input_ && (er.delays.back() > 0 || er.transform == Transform::kLowPass)) {
      input_past_ = true;
    }
  }
  const ChannelInfo& in = Channel(channels, spec.monotone_in);
  limits_.e_min = in.has_range ? in.min : 0.0;
  limits_.e_max = in.has_range ? in.max : 0.0;
  limits_.tolerance = DefaultSlopeTolerance(channels.front().scale, limits_.e_min, limits_.e_max);
  const int velocity = model_.ChannelIndex("v");
  const auto sign_of = [&](const State& st) {
    return velocity >= 0 ? Sign(st.raw[static_cast<std::size_t>(velocity)]) : 1;
  };

  // Visited states: every stride_-th scored sample.
  std::size_t scored = 0;
  const auto d0 = static_cast<std::size_t>(spec.MaxDelay());
  for (const DataSet& d : identification) scored += d.rows() - std::min(d.rows(), d0);
  stride_ = std::max<std::size_t>(1, (scored + kGateVisitedStates - 1) / kGateVisitedStates);
  for (const DataSet& d : identification) {
    sources_.push_back(d.path);
    std::vector<const std::vector<double>*> cols;
    for (const auto& s : signals) cols.push_back(&d.Column(s));
    for (std::size_t k = d0; k < d.rows(); k += stride_) {
      State st;
      st.source = sources_.size() - 1;
      st.row = k;
      for (std::size_t c = 0; c < signals.size(); ++c) {
        // The output and the command at k - 1 (what the state holds), inputs at k.
        const bool past = c == 0 || (c == input_ && input_past_);
        st.raw[c] = (*cols[c])[past && k > 0 ? k - 1 : k];
      }
      st.velocity_sign = sign_of(st);
      visited_.push_back(st);
    }
  }
  // Grid states over every signal's envelope (the command: its past over its range), each
  // held in steady state.
  sources_.push_back("grid");
  std::vector<std::vector<double>> axes;
  for (std::size_t c = 0; c < signals.size(); ++c) {
    const ChannelInfo& ci = Channel(channels, signals[c]);
    if (c == input_) {
      axes.push_back(input_past_ ? GridAxis(limits_.e_min, limits_.e_max, kGridInput)
                                 : std::vector<double>{limits_.e_min});
    } else {
      axes.push_back(
          GridAxis(ci.min, ci.max, static_cast<int>(c) == velocity ? kGridVelocity : kGridOther));
    }
  }
  std::vector<std::size_t> at(signals.size(), 0);
  std::array<double, kMaxChannels> norm{};
  const std::span<const double> s(norm.data(), model_.num_channels);
  for (bool more = true; more;) {
    State st;
    st.source = sources_.size() - 1;
    for (std::size_t c = 0; c < signals.size(); ++c) {
      st.raw[c] = axes[c][at[c]];
      norm[c] = Normalise(model_.scales[c], st.raw[c]);
    }
    st.velocity_sign = sign_of(st);
    grid_.push_back(st);
    RegressorHistory& h = grid_histories_.emplace_back();
    h.Reset(model_);
    h.Hold(model_, s);
    h.PushInputs(model_, s);
    bool corner = true;  // every axis at an end; the velocity also next to 0
    for (std::size_t c = 0; c < signals.size(); ++c) {
      const std::size_t n = axes[c].size();
      const bool end = at[c] == 0 || at[c] + 1 == n;
      const bool near_zero =
          static_cast<int>(c) == velocity && (2 * at[c] + 2 == n || 2 * at[c] == n);
      corner = corner && (end || near_zero);
    }
    if (corner) {
      screen_.push_back(st);
      screen_histories_.push_back(h);
    }
    std::size_t c = 0;  // odometer, channel 0 fastest
    for (; c < signals.size(); ++c) {
      if (++at[c] < axes[c].size()) break;
      at[c] = 0;
    }
    more = c < signals.size();
  }
}

MonotoneGate::TermShape MonotoneGate::Shape(const SemTerm& term) const {
  TermShape sh;
  int degree = 0;
  bool low_pass = false;
  for (const SemFactor& f : term.factors) {
    const auto& reg = model_.regressors[static_cast<std::size_t>(f.regressor)];
    if (reg.channel != input_ || f.delay != 0) continue;
    sh.e_term = true;
    degree += f.power;
    low_pass = low_pass || reg.transform == Transform::kLowPass;
    if (reg.transform != Transform::kIdentity && reg.transform != Transform::kLowPass) {
      sh.problem = fmt::format("{} takes {}(k) through abs_pow, sign, tanh or clip",
                               TermName(spec_, term), spec_.monotone_in);
    }
  }
  if (!sh.e_term) return sh;
  if (sh.problem.empty() && degree > kMaxInputDegree) {
    sh.problem = fmt::format("{} has degree {} in {}(k) > {}", TermName(spec_, term), degree,
                             spec_.monotone_in, kMaxInputDegree);
  }
  if (sh.problem.empty() && term.factors.size() > kMaxFactors) {
    sh.problem = fmt::format("{} has {} factors > {}", TermName(spec_, term), term.factors.size(),
                             kMaxFactors);
  }
  if (!sh.problem.empty()) return sh;
  sh.hi = static_cast<std::size_t>(degree);
  sh.lo = low_pass ? 1 : sh.hi;
  sh.term.num_factors = static_cast<std::uint8_t>(term.factors.size());
  for (std::size_t k = 0; k < term.factors.size(); ++k) {
    const SemFactor& f = term.factors[k];
    sh.term.factors[k] = {static_cast<std::uint8_t>(f.regressor),
                          static_cast<std::uint8_t>(f.delay), static_cast<std::uint8_t>(f.power)};
  }
  return sh;
}

MonotoneGate::TermPart MonotoneGate::ComputePart(const SemTerm& term, Segment seg) const {
  TermPart part;
  part.shape = Shape(term);
  const TermShape& sh = part.shape;
  if (!sh.e_term || !sh.problem.empty()) return part;
  const std::size_t width = sh.hi - sh.lo + 1;
  part.a.resize(States(seg).size() * width);
  const auto keep = [&](std::size_t i, const RegressorHistory& h) {
    const auto p = TermInputPolynomial(model_, sh.term, input_, h);
    for (std::size_t j = 0; j < width; ++j) part.a[i * width + j] = p[sh.lo + j];
  };
  if (seg != kVisited) {
    const auto& histories = seg == kGrid ? grid_histories_ : screen_histories_;
    for (std::size_t i = 0; i < histories.size(); ++i) keep(i, histories[i]);
    return part;
  }
  // The visited states' histories from the measured data (the output fed back).
  const auto signals = spec_.Signals();
  const auto d0 = static_cast<std::size_t>(spec_.MaxDelay());
  std::size_t i = 0;
  std::array<double, kMaxChannels> row{};
  const std::span<const double> raw(row.data(), model_.num_channels);
  for (const DataSet& d : data_) {
    std::vector<const std::vector<double>*> cols;
    for (const auto& s : signals) cols.push_back(&d.Column(s));
    ModelRunner runner(model_);
    for (std::size_t k = 0; k < d.rows(); ++k) {
      for (std::size_t c = 0; c < signals.size(); ++c) row[c] = (*cols[c])[k];
      if (k < d0) {
        runner.Seed(raw);
        continue;
      }
      runner.Begin(raw);
      if ((k - d0) % stride_ == 0) keep(i++, runner.history());
      runner.Finish(row[0]);
    }
  }
  return part;
}

std::shared_ptr<const MonotoneGate::TermPart> MonotoneGate::Part(const SemTerm& term,
                                                                 Segment seg) const {
  // The term's factors as they are (regressor, delay, power; 16 bits each): asked for every
  // term of every candidate the search screens, so no formatting and a shared lock.
  std::string key;
  key.reserve(6 * term.factors.size());
  for (const SemFactor& f : term.factors) {
    for (const int v : {f.regressor, f.delay, f.power}) {
      key.push_back(static_cast<char>(v & 0xff));
      key.push_back(static_cast<char>((v >> 8) & 0xff));
    }
  }
  {
    const std::shared_lock<std::shared_mutex> lock(mu_);
    const auto it = parts_[seg].find(key);
    if (it != parts_[seg].end()) return it->second;
  }
  auto part = std::make_shared<const TermPart>(ComputePart(term, seg));
  const std::unique_lock<std::shared_mutex> lock(mu_);
  return parts_[seg].emplace(std::move(key), std::move(part)).first->second;  // first writer wins
}

long MonotoneGate::Run(const std::vector<SemTerm>& terms, const std::vector<double>& theta,
                       bool screen, MonotoneVerdict* v) const {
  const BasicChannelScale<double> in = model_.scales[input_], out = model_.scales[0];
  long first = -1;
  long index = 0;  // of the state over the segments
  double worst = 0.0;
  bool have_worst = false;
  Segment worst_seg = kGrid;
  std::size_t worst_state = 0;
  StateInvertibility worst_verdict;
  for (const Segment seg : {kScreen, kGrid, kVisited}) {
    if ((seg == kScreen) != screen) continue;
    std::vector<std::shared_ptr<const TermPart>> parts;
    std::vector<double> th;
    for (std::size_t t = 0; t < terms.size(); ++t) {
      auto p = Part(terms[t], seg);
      if (!p->shape.problem.empty()) {
        if (v != nullptr) {
          v->states = states();
          v->failing = states();
          v->share_percent = 100.0;
          v->pass = false;
          v->worst = p->shape.problem;
        }
        return 0;
      }
      if (p->a.empty()) continue;  // no E(k) factor
      parts.push_back(std::move(p));
      th.push_back(theta[t]);
    }
    const std::vector<State>& states = States(seg);
    for (std::size_t i = 0; i < states.size(); ++i, ++index) {
      std::array<double, kMaxInputDegree + 1> a{};
      // In term order, as InputPolynomial sums them: the same bits.
      for (std::size_t t = 0; t < parts.size(); ++t) {
        const TermShape& sh = parts[t]->shape;
        const std::size_t width = sh.hi - sh.lo + 1;
        for (std::size_t j = 0; j < width; ++j) a[sh.lo + j] += th[t] * parts[t]->a[i * width + j];
      }
      const StateInvertibility s =
          CheckInputPolynomial(a, in, out, states[i].velocity_sign, limits_);
      if (!s.ok() && first < 0) first = index;
      if (v == nullptr) {
        if (first >= 0) return first;
        continue;
      }
      if (!s.ok()) ++v->failing;
      if (!have_worst || s.worst_slope < worst || !std::isfinite(s.worst_slope)) {
        have_worst = true;
        worst = s.worst_slope;
        worst_seg = seg;
        worst_state = i;
        worst_verdict = s;
      }
    }
  }
  if (v != nullptr) {
    v->states = static_cast<std::size_t>(index);
    v->pass = v->failing == 0;
    v->share_percent =
        index == 0 ? 0.0 : 100.0 * static_cast<double>(v->failing) / static_cast<double>(index);
    if (have_worst) v->worst = Describe(worst_seg, worst_state, worst_verdict);
  }
  return first;
}

std::string MonotoneGate::Describe(Segment seg, std::size_t i, const StateInvertibility& s) const {
  const State& st = States(seg)[i];
  const auto signals = spec_.Signals();
  std::string values;
  for (std::size_t c = 0; c < signals.size(); ++c) {
    if (c == input_ && !input_past_) continue;
    const bool past = c == 0 || c == input_;
    values += fmt::format("{}{}{} = {:.4g}", values.empty() ? "" : ", ", signals[c],
                          past ? "(k-1)" : "", st.raw[c]);
  }
  const std::string& src = sources_[st.source];
  return fmt::format(
      "{} ({}): d{}/d{} * sign(v) = {:.4g} at {} = {:.4g}", values,
      seg != kVisited ? std::string("envelope grid") : fmt::format("{} row {}", src, st.row),
      spec_.output, spec_.monotone_in, s.worst_slope, spec_.monotone_in, s.worst_e);
}

MonotoneVerdict MonotoneGate::Check(const std::vector<SemTerm>& terms,
                                    const std::vector<double>& theta) const {
  MonotoneVerdict v;
  v.checked = true;
  Run(terms, theta, false, &v);
  return v;
}

bool MonotoneGate::Passes(const std::vector<SemTerm>& terms,
                          const std::vector<double>& theta) const {
  return Run(terms, theta, false, nullptr) < 0;
}

bool MonotoneGate::PassesScreen(const std::vector<SemTerm>& terms,
                                const std::vector<double>& theta) const {
  return Run(terms, theta, true, nullptr) < 0;
}

}  // namespace mrd::host::internal
