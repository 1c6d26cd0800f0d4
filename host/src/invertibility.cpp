#include "mrd/host/invertibility.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

#include "mrd/common/table.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host {
namespace {

// What the grid and the messages need to know about the model's channels.
struct Layout {
  std::size_t input = 0, output = 0;
  int velocity = -1;        // channel index, -1: none
  bool input_past = false;  // the command's past enters (delay >= 1 or a low-pass)
};

Layout MakeLayout(const Model& m, std::size_t input, const std::string& velocity) {
  Layout l;
  l.input = input;
  l.output = m.output_channel;
  l.velocity = m.ChannelIndex(velocity.c_str());
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    for (const Factor& f : m.terms[i].active()) {
      const Regressor& r = m.regressors[f.regressor];
      if (r.channel == input && (f.delay > 0 || r.transform == Transform::kLowPass)) {
        l.input_past = true;
      }
    }
  }
  return l;
}

// Values of a state for messages: inputs at k, the output and the command at k - 1.
std::vector<std::pair<std::string, double>> StateValues(const Model& m, const Layout& l,
                                                        std::span<const double> now, double y_prev,
                                                        double input_prev) {
  std::vector<std::pair<std::string, double>> v;
  for (std::size_t c = 0; c < m.num_channels; ++c) {
    if (c == l.input || c == l.output) continue;
    v.emplace_back(m.channel_names[c].data(), now[c]);
  }
  v.emplace_back(fmt::format("{}(k-1)", m.channel_names[l.output].data()), y_prev);
  if (l.input_past)
    v.emplace_back(fmt::format("{}(k-1)", m.channel_names[l.input].data()), input_prev);
  return v;
}

class Checker {
 public:
  Checker(const Model& m, const Layout& l, const InvertibilityLimits& lim, InvertibilityReport* r)
      : m_(m), l_(l), lim_(lim), r_(*r) {}

  // One state: the verdict counted; the worst kept (values built only when it is).
  template <class Values>
  bool Check(const RegressorHistory& h, double velocity, bool grid, const Values& values) {
    const StateInvertibility v = CheckStateInvertibility(m_, l_.input, h, velocity, lim_);
    (grid ? r_.grid_states : r_.visited_states)++;
    if (!v.ok()) (grid ? r_.grid_failing : r_.visited_failing)++;
    if (!v.monotone) ++r_.non_monotone;
    if (!v.one_to_one) ++r_.not_one_to_one;
    const bool worse =
        !r_.has_worst || v.worst_slope < r_.worst.verdict.worst_slope ||
        (!std::isfinite(v.worst_slope) && std::isfinite(r_.worst.verdict.worst_slope));
    if (worse) {
      r_.has_worst = true;
      r_.worst = values();
      r_.worst.verdict = v;
    }
    return v.ok();
  }

 private:
  const Model& m_;
  const Layout& l_;
  const InvertibilityLimits& lim_;
  InvertibilityReport& r_;
};

void CheckVisited(const Model& m, const Layout& l, Checker& checker, const DataSet& d) {
  std::vector<const std::vector<double>*> cols(m.num_channels);
  for (std::size_t c = 0; c < m.num_channels; ++c) cols[c] = &d.Column(m.channel_names[c].data());
  ModelRunner runner(m);
  const std::size_t d0 = m.MaxDelay();
  std::array<double, kMaxChannels> row{};
  const std::span<const double> raw(row.data(), m.num_channels);
  for (std::size_t k = 0; k < d.rows(); ++k) {
    for (std::size_t c = 0; c < m.num_channels; ++c) row[c] = (*cols[c])[k];
    if (k < d0) {
      runner.Seed(raw);
      continue;
    }
    runner.Begin(raw);
    const double v = l.velocity >= 0 ? row[static_cast<std::size_t>(l.velocity)] : 1.0;
    checker.Check(runner.history(), v, false, [&] {
      InvertibilityState s;
      s.source = d.path;
      s.row = k;
      s.values = StateValues(m, l, raw, k > 0 ? (*cols[l.output])[k - 1] : 0.0,
                             k > 0 ? (*cols[l.input])[k - 1] : 0.0);
      return s;
    });
    runner.Finish(row[l.output]);
  }
}

void CheckGrid(const Model& m, const Layout& l, const InvertibilitySettings& set, Checker& checker,
               std::span<const SignalRange> envelope) {
  // Axes per channel (the command: its past, or one value when the model has none).
  std::vector<std::vector<double>> axis(m.num_channels);
  for (std::size_t c = 0; c < m.num_channels; ++c) {
    if (c == l.input) {
      axis[c] = l.input_past ? GridAxis(set.e_min, set.e_max, kGridInput) : std::vector{set.e_min};
      continue;
    }
    const auto r = std::find_if(envelope.begin(), envelope.end(), [&](const SignalRange& s) {
      return s.name == m.channel_names[c].data();
    });
    if (r == envelope.end()) return;  // no range recorded: no grid
    axis[c] =
        GridAxis(r->min, r->max, static_cast<int>(c) == l.velocity ? kGridVelocity : kGridOther);
  }
  std::vector<std::size_t> at(m.num_channels, 0);
  std::array<double, kMaxChannels> raw{}, norm{};
  RegressorHistory h;
  h.Reset(m);
  for (;;) {
    for (std::size_t c = 0; c < m.num_channels; ++c) {
      raw[c] = axis[c][at[c]];
      norm[c] = Normalise(m.scales[c], raw[c]);
    }
    const std::span<const double> s(norm.data(), m.num_channels);
    h.Hold(m, s);
    h.PushInputs(m, s);
    const double v = l.velocity >= 0 ? raw[static_cast<std::size_t>(l.velocity)] : 1.0;
    checker.Check(h, v, true, [&] {
      InvertibilityState st;
      st.source = "grid";
      st.values = StateValues(m, l, std::span<const double>(raw.data(), m.num_channels),
                              raw[l.output], raw[l.input]);
      return st;
    });
    std::size_t c = 0;  // odometer
    for (; c < m.num_channels; ++c) {
      if (++at[c] < axis[c].size()) break;
      at[c] = 0;
    }
    if (c == m.num_channels) break;
  }
}

}  // namespace

std::vector<double> GridAxis(double lo, double hi, int n) {
  if (!(hi > lo) || n <= 1) return {lo};
  std::vector<double> a;
  for (int i = 0; i < n; ++i) a.push_back(lo + (hi - lo) * i / (n - 1));
  return a;
}

double InvertibilityReport::share_percent() const {
  if (!structure_problem.empty()) return 100.0;
  return states() == 0 ? 0.0
                       : 100.0 * static_cast<double>(failing()) / static_cast<double>(states());
}

InvertibilityReport CheckInvertibility(const Model& model, const InvertibilitySettings& set,
                                       std::span<const SignalRange> envelope,
                                       std::span<const DataSet> visited) {
  InvertibilityReport r;
  r.input = set.input;
  r.output = model.channel_names[model.output_channel].data();
  r.e_min = set.e_min;
  r.e_max = set.e_max;
  r.tolerance =
      set.tolerance >= 0.0
          ? set.tolerance
          : DefaultSlopeTolerance(model.scales[model.output_channel].scale, set.e_min, set.e_max);
  const int input = model.ChannelIndex(set.input.c_str());
  if (input < 0 || input == model.output_channel) {
    r.reads_input = false;  // flat in the command: nothing can fail
    return r;
  }
  CoefficientTable table;
  table.model = model;
  table.input_channel = static_cast<std::uint8_t>(input);
  const InversionCheck inv = CheckInversion(table);
  switch (inv.problem) {
    case InversionProblem::kNone:
      break;
    case InversionProblem::kAbsent:
      r.reads_input = false;
      break;
    case InversionProblem::kTransform:
      r.structure_problem = fmt::format(
          "term {} takes {}(k) through abs_pow, sign, tanh or clip (not a polynomial in {}(k))",
          inv.term, set.input, set.input);
      return r;
    case InversionProblem::kDegree:
      r.structure_problem = fmt::format("term {} has degree {} in {}(k) > {}", inv.term, inv.degree,
                                        set.input, kMaxInputDegree);
      return r;
  }
  const Layout l = MakeLayout(model, static_cast<std::size_t>(input), set.velocity);
  const InvertibilityLimits lim{set.e_min, set.e_max, r.tolerance};
  Checker checker(model, l, lim, &r);
  for (const DataSet& d : visited) CheckVisited(model, l, checker, d);
  CheckGrid(model, l, set, checker, envelope);
  return r;
}

std::string ModelCommand(const ModelFile& m) {
  if (!m.spec.monotone_in.empty()) return m.spec.monotone_in;
  const auto signals = m.spec.Signals();
  return std::find(signals.begin() + 1, signals.end(), "E") != signals.end() ? "E" : "";
}

InvertibilityReport CheckModelInvertibility(const ModelFile& m, int k,
                                            std::span<const DataSet> visited,
                                            std::optional<std::pair<double, double>> e_range) {
  InvertibilitySettings set;
  set.input = ModelCommand(m);
  std::vector<SignalRange> envelope;
  for (const ChannelInfo& c : m.channels) {
    if (c.has_range) envelope.push_back({c.name, c.min, c.max});
    if (c.name == set.input && c.has_range) {
      set.e_min = c.min;
      set.e_max = c.max;
    }
  }
  if (e_range) std::tie(set.e_min, set.e_max) = *e_range;
  return CheckInvertibility(ToRuntimeModel(m, k), set, envelope, visited);
}

InvertibilityReport RecordInvertibility(ModelFile* m, std::span<const DataSet> identification) {
  const InvertibilityReport r = CheckModelInvertibility(*m, m->selected, identification);
  InvertibilityRecord& rec = m->invertibility;
  rec.recorded = true;
  rec.iteration = m->selected;
  rec.input = r.input;
  rec.e_min = r.e_min;
  rec.e_max = r.e_max;
  rec.states = r.states();
  rec.failing = r.failing();
  rec.share_percent = r.share_percent();
  rec.summary = InvertibilitySummary(r);
  return r;
}

InvertibilityReport ExportInvertibility(const ModelFile& m, const std::string& input,
                                        const CoefficientTable& table) {
  std::vector<DataSet> visited;
  try {
    for (const std::string& path : m.identification_data) visited.push_back(ReadCsv(path));
  } catch (const std::exception&) {
    visited.clear();  // moved or changed since: the grid alone
  }
  InvertibilitySettings set;
  set.input = input;
  set.e_min = table.e_min;
  set.e_max = table.e_max;
  std::vector<SignalRange> envelope;
  for (const ChannelInfo& c : m.channels) {
    if (c.has_range) envelope.push_back({c.name, c.min, c.max});
  }
  try {
    return CheckInvertibility(table.model, set, envelope, visited);
  } catch (const InputError&) {  // a data file without a channel of the model: the grid alone
    return CheckInvertibility(table.model, set, envelope, {});
  }
}

void RecordTableInvertibility(const InvertibilityReport& r, CoefficientTable* table) {
  const auto clamp32 = [](std::size_t n) {
    return static_cast<std::uint32_t>(std::min<std::size_t>(n, 0xFFFFFFFFu));
  };
  table->has_invertibility = true;
  table->invertibility.states = clamp32(r.states());
  table->invertibility.failing = std::min(
      table->invertibility.states, clamp32(r.structure_problem.empty() ? r.failing() : r.states()));
  table->invertibility.worst_slope =
      r.has_worst && std::isfinite(r.worst.verdict.worst_slope) ? r.worst.verdict.worst_slope : 0.0;
}

nlohmann::json InvertibilityJson(const InvertibilityReport& r) {
  nlohmann::json j = {{"input", r.input},
                      {"e_min", r.e_min},
                      {"e_max", r.e_max},
                      {"tolerance", r.tolerance},
                      {"states", r.states()},
                      {"failing", r.failing()},
                      {"share_percent", r.share_percent()},
                      {"visited_states", r.visited_states},
                      {"grid_states", r.grid_states},
                      {"non_monotone", r.non_monotone},
                      {"not_one_to_one", r.not_one_to_one},
                      {"reads_input", r.reads_input},
                      {"pass", r.pass()}};
  if (!r.structure_problem.empty()) j["structure_problem"] = r.structure_problem;
  if (r.has_worst) {
    j["worst"] = DescribeState(r, r.worst);
    j["worst_slope"] = std::isfinite(r.worst.verdict.worst_slope)
                           ? nlohmann::json(r.worst.verdict.worst_slope)
                           : nlohmann::json();
  }
  return j;
}

std::string DescribeState(const InvertibilityReport& r, const InvertibilityState& s) {
  std::string values;
  for (const auto& [name, v] : s.values) {
    values += fmt::format("{}{} = {:.4g}", values.empty() ? "" : ", ", name, v);
  }
  const std::string where =
      s.source == "grid" ? std::string("envelope grid") : fmt::format("{} row {}", s.source, s.row);
  return fmt::format("{} ({}): d{}/d{} * sign(v) = {:.4g} at {} = {:.4g}", values, where, r.output,
                     r.input, s.verdict.worst_slope, r.input, s.verdict.worst_e);
}

std::string InvertibilitySummary(const InvertibilityReport& r) {
  const std::string head =
      fmt::format("invertibility in {} on [{:g}, {:g}]", r.input, r.e_min, r.e_max);
  if (!r.structure_problem.empty()) {
    return fmt::format("{}: FAIL, {}", head, r.structure_problem);
  }
  if (!r.reads_input) return fmt::format("{}: {}(k) does not enter the model", head, r.input);
  std::string s = fmt::format(
      "{}: {} of {} states fail ({:.3g} %; {} visited by the data, {} on "
      "the envelope grid; slopes within +-{:.3g} count as flat)",
      head, r.failing(), r.states(), r.share_percent(), r.visited_states, r.grid_states,
      r.tolerance);
  if (r.failing() > 0) {
    s += fmt::format("; {} fall as {} rises in the dissipative direction, {} not one-to-one",
                     r.non_monotone, r.input, r.not_one_to_one);
  }
  if (r.has_worst) s += fmt::format("; worst: {}", DescribeState(r, r.worst));
  return s;
}

}  // namespace mrd::host
