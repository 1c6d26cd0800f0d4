#include "mrd/host/model_file.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "mrd/common/input_file.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/table_export.hpp"
#include "sem/spec/spec_table.hpp"

namespace mrd::host {
namespace {

using nlohmann::json;

const char* TransformName(Transform t) {
  switch (t) {
    case Transform::kIdentity:
      return "identity";
    case Transform::kAbsPow:
      return "abs_pow";
    case Transform::kSign:
      return "sign";
    case Transform::kLowPass:
      return "low_pass";
    case Transform::kTanh:
      return "tanh";
    case Transform::kClip:
      return "clip";
  }
  return "identity";
}

json SpecToJson(const SemSpec& s) {
  json regs = json::array();
  for (const auto& r : s.regressors) {
    json j = {{"name", r.name},
              {"signal", r.signal},
              {"transform", TransformName(r.transform)},
              {"powers", r.powers},
              {"delays", r.delays}};
    if (r.transform == Transform::kAbsPow) j["exponent"] = r.exponent;
    if (r.transform == Transform::kLowPass) j["tau"] = r.exponent;
    if (r.transform == Transform::kTanh) j["scale"] = r.exponent;
    if (r.transform == Transform::kClip) j["limit"] = r.exponent;
    regs.push_back(j);
  }
  json out = {{"output", s.output},
              {"regressor", regs},
              {"limits",
               {{"max_factors", s.max_factors},
                {"max_degree", s.max_degree},
                {"constant", s.constant},
                {"max_candidates", s.max_candidates}}},
              {"cost",
               {{"weighting", s.weighting == CostWeighting::kRelative ? "relative" : "mse"},
                {"floor", s.floor}}},
              {"algorithm",
               {{"strategy", s.strategy == Strategy::kBest ? "best" : "first"},
                {"threshold_percent", s.threshold_percent},
                {"max_iterations", s.max_iterations},
                {"target_j", s.target_j},
                {"divergence_limit", s.divergence_limit},
                {"selection",
                 s.selection == Selection::kCrossValidation ? "cross_validation" : "tolerance"},
                {"selection_tolerance_percent", s.selection_tolerance_percent},
                {"initial", s.initial}}}};
  if (!s.monotone_in.empty()) out["algorithm"]["monotone_in"] = s.monotone_in;
  if (s.stress.enabled) {
    out["stress"] = {{"stretch", s.stress.stretch},
                     {"stretch_signals", s.stress.stretch_signals},
                     {"sweep_signals", s.stress.sweep_signals},
                     {"sweep_period", s.stress.sweep_period},
                     {"hold", s.stress.hold},
                     {"rest", s.stress.rest},
                     {"force_bound", s.stress.force_bound}};
  }
  return out;
}

// The spec is stored in the same shape as the TOML: the JSON becomes a TOML table in memory
// (no text in between, so values keep full precision) and goes through the spec file's own
// validation (SemSpecFromTable).
std::unique_ptr<toml::node> JsonToToml(const json& v, const std::string& key,
                                       const std::string& path) {
  if (v.is_string()) return std::make_unique<toml::value<std::string>>(v.get<std::string>());
  if (v.is_boolean()) return std::make_unique<toml::value<bool>>(v.get<bool>());
  if (v.is_number_unsigned() &&
      v.get<std::uint64_t>() >
          static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
    throw InputError(path, 0, fmt::format("spec: '{}' = {} is too large", key, v.dump()));
  }
  if (v.is_number_integer())
    return std::make_unique<toml::value<std::int64_t>>(v.get<std::int64_t>());
  if (v.is_number()) return std::make_unique<toml::value<double>>(v.get<double>());
  if (v.is_array()) {
    auto arr = std::make_unique<toml::array>();
    for (const auto& e : v) arr->push_back(std::move(*JsonToToml(e, key, path)));
    return arr;
  }
  if (v.is_object()) {
    auto tbl = std::make_unique<toml::table>();
    for (const auto& [k, e] : v.items())
      tbl->insert(k, std::move(*JsonToToml(e, key + "." + k, path)));
    return tbl;
  }
  throw InputError(path, 0,
                   fmt::format("spec: '{}' is {}, expected a number, string, boolean, array or "
                               "table",
                               key, v.type_name()));
}

SemSpec SpecFromJson(const json& j, const std::string& path) {
  if (!j.is_object()) {
    throw InputError(
        path, 0,
        fmt::format("bad spec in model file: 'spec' must be an object, found {}", j.type_name()));
  }
  toml::table tbl;
  for (const auto& [k, v] : j.items()) tbl.insert(k, std::move(*JsonToToml(v, k, path)));
  try {
    return SemSpecFromTable(tbl, path);
  } catch (const InputError& e) {
    throw InputError(path, 0, fmt::format("bad spec in model file: {}", e.what()));
  }
}

// An integer field: a JSON integer (not 1.5, not a string) within [lo, hi]; anything else is
// refused naming the field, never converted.
int IntField(const json& obj, const std::string& key, long long lo, long long hi,
             const std::string& path, const std::string& where) {
  const json& v = obj.at(key);
  const std::string name = where.empty() ? key : where + ": " + key;
  if (!v.is_number_integer()) {
    throw InputError(path, 0, fmt::format("'{}' must be an integer, found {}", name, v.dump()));
  }
  const bool out_of_range =
      v.is_number_unsigned() ? v.get<unsigned long long>() > static_cast<unsigned long long>(hi) ||
                                   static_cast<long long>(v.get<unsigned long long>()) < lo
                             : v.get<long long>() < lo || v.get<long long>() > hi;
  if (out_of_range) {
    throw InputError(path, 0,
                     fmt::format("'{}' = {} out of range {} ... {}", name, v.dump(), lo, hi));
  }
  return static_cast<int>(v.get<long long>());
}

double FiniteField(const json& v, const std::string& name, const std::string& path) {
  if (!v.is_number()) {
    throw InputError(path, 0, fmt::format("'{}' must be a number, found {}", name, v.dump()));
  }
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw InputError(path, 0, fmt::format("'{}' is not finite", name));
  return d;
}

}  // namespace

const SemIteration& ModelFile::Iteration(int k) const {
  for (const auto& it : iterations) {
    if (it.iteration == k) return it;
  }
  throw InputError(path, 0,
                   fmt::format("no iteration {} (the file has 0 ... {})", k,
                               iterations.empty() ? 0 : iterations.back().iteration));
}

ModelFile MakeModelFile(const SemSpec& spec, const SemResult& r) {
  ModelFile m;
  m.spec = spec;
  m.channels = r.channels;
  m.iterations = r.iterations;
  m.selected = r.selected;
  m.num_candidates = r.num_candidates;
  m.selection_rule = r.selection_rule;
  return m;
}

std::string ModelFileToJson(const ModelFile& m) {
  json its = json::array();
  for (const auto& it : m.iterations) {
    json terms = json::array();
    for (std::size_t t = 0; t < it.terms.size(); ++t) {
      json factors = json::array();
      for (const auto& f : it.terms[t].factors) {
        factors.push_back({{"regressor", m.spec.regressors[f.regressor].name},
                           {"delay", f.delay},
                           {"power", f.power}});
      }
      terms.push_back({{"coefficient", it.coefficients[t]},
                       {"name", TermName(m.spec, it.terms[t])},
                       {"factors", factors}});
    }
    json ji = {{"iteration", it.iteration},
               {"J", it.j},
               {"validation_J", it.validation_j},
               {"elapsed_s", it.elapsed_s},
               {"terms", terms}};
    if (it.stress.checked) {
      ji["stress"] = {{"pass", it.stress.pass},
                      {"peak", std::isfinite(it.stress.peak) ? json(it.stress.peak) : json()},
                      {"reason", it.stress.reason},
                      {"rejected_candidates", it.stress_rejected}};
    }
    if (it.monotone.checked) {  // spec monotone_in: the search's invertibility verdict
      ji["monotone"] = {
          {"pass", it.monotone.pass},       {"states", it.monotone.states},
          {"failing", it.monotone.failing}, {"share_percent", it.monotone.share_percent},
          {"worst", it.monotone.worst},     {"rejected_candidates", it.monotone_rejected}};
    }
    its.push_back(ji);
  }
  json ch = json::array();
  for (const auto& c : m.channels) {
    json jc = {{"name", c.name}, {"offset", c.offset}, {"scale", c.scale}};
    if (c.has_range) {  // operating envelope: range of the identification data [raw units]
      jc["min"] = c.min;
      jc["max"] = c.max;
    }
    ch.push_back(jc);
  }
  json j = {{"format", "mrd-sem-model"},
            {"version", 1},
            {"spec", SpecToJson(m.spec)},
            {"channels", ch},
            {"warmup_samples", m.warmup_samples()},
            {"num_candidates", m.num_candidates},
            {"iterations", its},
            {"selected", m.selected},
            {"selection_rule", m.selection_rule},
            {"identification_data", m.identification_data},
            {"validation_data", m.validation_data}};
  if (!m.family.empty()) j["family"] = FamilyToJson(m.family);
  if (m.invertibility.recorded) {
    const InvertibilityRecord& r = m.invertibility;
    j["invertibility"] = {{"iteration", r.iteration},
                          {"input", r.input},
                          {"e_min", r.e_min},
                          {"e_max", r.e_max},
                          {"states", r.states},
                          {"failing", r.failing},
                          {"share_percent", r.share_percent},
                          {"summary", r.summary}};
  }
  if (!m.spec_choice.empty()) j["spec_choice"] = SpecChoiceToJson(m.spec_choice);
  return j.dump(1) + "\n";
}

void SaveModelFile(const ModelFile& m, const std::string& path) {
  for (const auto& it : m.iterations) {
    for (const double c : it.coefficients) {
      if (!std::isfinite(c)) {
        throw InputError(
            path, 0, fmt::format("iteration {}: non-finite coefficient not written", it.iteration));
      }
    }
  }
  WriteFileAtomic(path, ModelFileToJson(m));
}

namespace {

// One entry of "iterations" (its terms checked against the spec; its number not one of earlier).
SemIteration IterationFromJson(const json& ji, const SemSpec& spec,
                               const std::vector<SemIteration>& earlier, const std::string& path) {
  SemIteration it;
  it.iteration = IntField(ji, "iteration", 0, 1000000, path, "iterations[]");
  for (const auto& prev : earlier) {
    if (prev.iteration == it.iteration) {
      throw InputError(path, 0, fmt::format("iteration {} appears twice", it.iteration));
    }
  }
  it.j = ji.at("J").is_null() ? std::numeric_limits<double>::infinity() : ji.at("J").get<double>();
  for (const auto& v : ji.at("validation_J")) {
    it.validation_j.push_back(v.is_null() ? std::numeric_limits<double>::infinity()
                                          : v.get<double>());
  }
  it.elapsed_s = ji.value("elapsed_s", 0.0);
  if (ji.contains("stress")) {
    const json& js = ji.at("stress");
    it.stress.checked = true;
    it.stress.pass = js.at("pass").get<bool>();
    it.stress.peak = js.at("peak").is_null() ? std::numeric_limits<double>::infinity()
                                             : js.at("peak").get<double>();
    it.stress.reason = js.value("reason", std::string());
    it.stress_rejected = js.value("rejected_candidates", 0);
  }
  if (ji.contains("monotone")) {
    const json& jm = ji.at("monotone");
    it.monotone.checked = true;
    it.monotone.pass = jm.at("pass").get<bool>();
    it.monotone.states = jm.at("states").get<std::size_t>();
    it.monotone.failing = jm.at("failing").get<std::size_t>();
    it.monotone.share_percent =
        FiniteField(jm.at("share_percent"), "monotone: share_percent", path);
    it.monotone.worst = jm.value("worst", std::string());
    it.monotone_rejected = jm.value("rejected_candidates", 0);
  }
  for (const auto& jt : ji.at("terms")) {
    SemTerm term;
    for (const auto& jf : jt.at("factors")) {
      const std::string name = jf.at("regressor").get<std::string>();
      const int r = spec.RegressorIndex(name);
      if (r < 0) {
        throw InputError(path, 0,
                         fmt::format("iteration {}: unknown regressor '{}'", it.iteration, name));
      }
      const std::string where = fmt::format("iteration {}: factor {}", it.iteration, name);
      const int delay = IntField(jf, "delay", 0, static_cast<long long>(kMaxDelay), path, where);
      const auto& offered = spec.regressors[static_cast<std::size_t>(r)].delays;
      if (std::find(offered.begin(), offered.end(), delay) == offered.end()) {
        throw InputError(path, 0,
                         fmt::format("'{}: delay' = {} is not offered by the spec", where, delay));
      }
      const int power = IntField(jf, "power", 1, kMaxPower, path, where);
      term.factors.push_back({r, delay, power});
    }
    it.terms.push_back(std::move(term));
    it.coefficients.push_back(FiniteField(
        jt.at("coefficient"), fmt::format("iteration {}: coefficient", it.iteration), path));
  }
  return it;
}

}  // namespace

ModelFile LoadModelFile(const std::string& path) {
  const std::string text = ReadInputText(path, kMaxModelFileBytes);
  // A key given twice in one object is refused (JSON leaves it open; the last would win).
  std::vector<std::set<std::string>> open_objects;
  const json::parser_callback_t refuse_repeats = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) open_objects.emplace_back();
    if (event == json::parse_event_t::object_end && !open_objects.empty()) open_objects.pop_back();
    if (event == json::parse_event_t::key && !open_objects.empty() &&
        !open_objects.back().insert(parsed.get<std::string>()).second) {
      throw InputError(
          path, 0,
          fmt::format("key '{}' given twice in one object", Printable(parsed.get<std::string>())));
    }
    return true;
  };
  json j;
  try {
    j = json::parse(text, refuse_repeats);
  } catch (const json::exception& e) {  // parse_error, out_of_range (1e400), ...
    throw InputError(path, 0, fmt::format("malformed JSON: {}", e.what()));
  }
  ModelFile m;
  m.path = path;
  try {
    if (j.at("format").get<std::string>() != "mrd-sem-model") {
      throw InputError(path, 0, "not an mrd model file (format != mrd-sem-model)");
    }
    if (j.at("version").get<int>() != 1) {
      throw InputError(path, 0, fmt::format("unsupported version {}", j.at("version").dump()));
    }
    m.spec = SpecFromJson(j.at("spec"), path);
    if (j.contains("identification_data")) {
      m.identification_data = j.at("identification_data").get<std::vector<std::string>>();
    }
    if (j.contains("validation_data")) {
      m.validation_data = j.at("validation_data").get<std::vector<std::string>>();
    }
    for (const auto& c : j.at("channels")) {
      ChannelInfo ci{c.at("name").get<std::string>(), c.at("offset").get<double>(),
                     c.at("scale").get<double>()};
      if (!(ci.scale > 0.0) || !std::isfinite(ci.scale) || !std::isfinite(ci.offset)) {
        throw InputError(path, 0, fmt::format("channel '{}': bad scale", ci.name));
      }
      if (c.contains("min") || c.contains("max")) {
        ci.has_range = true;
        ci.min = FiniteField(c.at("min"), fmt::format("channel '{}': min", ci.name), path);
        ci.max = FiniteField(c.at("max"), fmt::format("channel '{}': max", ci.name), path);
        if (!(ci.min <= ci.max)) {
          throw InputError(
              path, 0,
              fmt::format("channel '{}': envelope min {} > max {}", ci.name, ci.min, ci.max));
        }
      }
      m.channels.push_back(ci);
    }
    const auto signals = m.spec.Signals();
    if (m.channels.size() != signals.size()) {
      throw InputError(path, 0, "channels do not match the spec's signals");
    }
    for (std::size_t i = 0; i < signals.size(); ++i) {
      if (m.channels[i].name != signals[i]) {
        throw InputError(
            path, 0,
            fmt::format("channel {} is '{}', expected '{}'", i, m.channels[i].name, signals[i]));
      }
    }
    m.num_candidates = j.value("num_candidates", std::size_t{0});
    for (const auto& ji : j.at("iterations")) {
      m.iterations.push_back(IterationFromJson(ji, m.spec, m.iterations, path));
    }
    m.selected = IntField(j, "selected", 0, 1000000, path, "");
    m.selection_rule = j.value("selection_rule", std::string());
    if (j.contains("family")) m.family = FamilyFromJson(j.at("family"), m.spec, path);
    if (j.contains("invertibility")) {
      const json& ji = j.at("invertibility");
      InvertibilityRecord& r = m.invertibility;
      r.recorded = true;
      r.iteration = IntField(ji, "iteration", 0, 1000000, path, "invertibility");
      r.input = ji.at("input").get<std::string>();
      r.e_min = FiniteField(ji.at("e_min"), "invertibility: e_min", path);
      r.e_max = FiniteField(ji.at("e_max"), "invertibility: e_max", path);
      r.states = ji.at("states").get<std::size_t>();
      r.failing = ji.at("failing").get<std::size_t>();
      r.share_percent = FiniteField(ji.at("share_percent"), "invertibility: share_percent", path);
      r.summary = ji.value("summary", std::string());
    }
    if (j.contains("spec_choice")) m.spec_choice = SpecChoiceFromJson(j.at("spec_choice"), path);
  } catch (const json::exception& e) {
    throw InputError(path, 0, fmt::format("bad model file: {}", e.what()));
  }
  m.Iteration(m.selected);  // must exist
  return m;
}

mrd::Model ToRuntimeModel(const ModelFile& m, int iteration) {
  const SemIteration& it = m.Iteration(iteration);
  auto fail = [&](const std::string& why) {
    return InputError(
        m.path, 0, fmt::format("iteration {} does not fit the runtime model: {}", iteration, why));
  };
  mrd::Model model;
  if (it.terms.size() > kMaxTerms) {
    throw fail(fmt::format("{} terms > capacity {}", it.terms.size(), kMaxTerms));
  }
  // Channels: output first, then those the terms read, in spec signal order.
  std::vector<int> reg_map(m.spec.regressors.size(), -1);
  std::vector<std::string> chans{m.spec.output};
  std::vector<int> used_regs;
  for (const auto& t : it.terms) {
    for (const auto& f : t.factors) {
      if (f.regressor < 0 || f.regressor >= static_cast<int>(reg_map.size())) {
        throw fail("factor names an unknown regressor");
      }
      if (reg_map[f.regressor] < 0) {
        reg_map[f.regressor] = 0;
        used_regs.push_back(f.regressor);
      }
    }
  }
  std::sort(used_regs.begin(), used_regs.end());
  if (used_regs.size() > kMaxRegressors) {
    throw fail(
        fmt::format("{} elementary regressors > capacity {}", used_regs.size(), kMaxRegressors));
  }
  for (std::size_t i = 0; i < used_regs.size(); ++i) {
    const auto& r = m.spec.regressors[used_regs[i]];
    reg_map[used_regs[i]] = static_cast<int>(i);
    if (std::find(chans.begin(), chans.end(), r.signal) == chans.end()) chans.push_back(r.signal);
  }
  if (chans.size() > kMaxChannels) {
    throw fail(fmt::format("{} channels > capacity {}", chans.size(), kMaxChannels));
  }
  model.num_channels = static_cast<std::uint8_t>(chans.size());
  model.output_channel = 0;
  for (std::size_t c = 0; c < chans.size(); ++c) {
    if (chans[c].size() > kMaxNameLength) {
      throw fail(
          fmt::format("channel name '{}' longer than {} characters", chans[c], kMaxNameLength));
    }
    std::memcpy(model.channel_names[c].data(), chans[c].c_str(), chans[c].size() + 1);
    const auto ch = std::find_if(m.channels.begin(), m.channels.end(),
                                 [&](const ChannelInfo& ci) { return ci.name == chans[c]; });
    model.scales[c] = {ch->offset, ch->scale};
  }
  model.num_regressors = static_cast<std::uint8_t>(used_regs.size());
  for (std::size_t i = 0; i < used_regs.size(); ++i) {
    const auto& r = m.spec.regressors[used_regs[i]];
    model.regressors[i].channel =
        static_cast<std::uint8_t>(std::find(chans.begin(), chans.end(), r.signal) - chans.begin());
    model.regressors[i].transform = r.transform;
    model.regressors[i].exponent = r.exponent;
  }
  model.num_terms = static_cast<std::uint8_t>(it.terms.size());
  for (std::size_t t = 0; t < it.terms.size(); ++t) {
    const auto& term = it.terms[t];
    if (term.factors.size() > kMaxFactors) {
      throw fail(fmt::format("term '{}' has {} factors > capacity {}", TermName(m.spec, term),
                             term.factors.size(), kMaxFactors));
    }
    model.terms[t].num_factors = static_cast<std::uint8_t>(term.factors.size());
    for (std::size_t k = 0; k < term.factors.size(); ++k) {
      const auto& f = term.factors[k];
      if (f.delay < 0 || f.delay > static_cast<int>(kMaxDelay)) {
        throw fail(fmt::format("delay {} out of range 0 ... {}", f.delay, kMaxDelay));
      }
      if (f.power < 1 || f.power > kMaxPower) {
        throw fail(fmt::format("power {} out of range 1 ... {}", f.power, kMaxPower));
      }
      model.terms[t].factors[k] = {static_cast<std::uint8_t>(reg_map[f.regressor]),
                                   static_cast<std::uint8_t>(f.delay),
                                   static_cast<std::uint8_t>(f.power)};
    }
    model.coefficients[t] = it.coefficients[t];
  }
  const Error e = model.Validate();
  if (e != Error::kOk) throw fail(fmt::format("invalid model ({})", ErrorName(e)));
  return model;
}

SimMetrics SimulateModel(const ModelFile& m, int iteration, const DataSet& data,
                         std::vector<double>* ysim_raw) {
  const mrd::Model model = ToRuntimeModel(m, iteration);
  std::vector<const std::vector<double>*> cols(model.num_channels);
  for (std::size_t c = 0; c < model.num_channels; ++c) {
    cols[c] = &data.Column(model.channel_names[c].data());
  }
  if (!data.Has(m.spec.output)) {
    throw InputError(data.path, 1, fmt::format("missing column '{}'", m.spec.output));
  }
  const auto& y = data.Column(m.spec.output);
  const std::size_t n = data.rows();
  const std::size_t d0 = static_cast<std::size_t>(m.warmup_samples());
  if (n <= d0) throw InputError(data.path, 0, "too few rows to simulate");
  mrd::ModelRunner runner(model);
  std::array<double, kMaxChannels> row{};
  const double scale = model.scales[0].scale;
  const double offset = model.scales[0].offset;
  SimMetrics r;
  double sse = 0.0, sj = 0.0, sy = 0.0, syy = 0.0;
  if (ysim_raw != nullptr) ysim_raw->assign(y.begin(), y.end());
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t c = 0; c < model.num_channels; ++c) row[c] = (*cols[c])[k];
    if (k < d0) {
      runner.Seed(std::span<const double>(row.data(), model.num_channels));
      continue;
    }
    const double yh = runner.Step(std::span<const double>(row.data(), model.num_channels));
    if (ysim_raw != nullptr) (*ysim_raw)[k] = yh;
    const double yn = (y[k] - offset) / scale;
    const double yhn = (yh - offset) / scale;
    if (!(std::fabs(yhn) <= m.spec.divergence_limit)) r.diverged = true;
    const double e = yn - yhn;
    const double w = m.spec.weighting == CostWeighting::kRelative
                         ? 1.0 / std::max(std::fabs(yn), m.spec.floor)
                         : 1.0;
    sj += w * e * e;
    sse += e * e;
    sy += yn;
    syy += yn * yn;
  }
  r.samples = n - d0;
  const double nn = static_cast<double>(r.samples);
  r.j = sj / nn;
  r.mse = sse / nn;
  r.mse_physical = r.mse * scale * scale;
  r.rmse_physical = std::sqrt(r.mse_physical);
  const double var = syy - sy * sy / nn;  // sum (y - mean)^2
  r.rrse = var > 0.0 ? std::sqrt(sse / var) : std::numeric_limits<double>::infinity();
  r.fit_percent = 100.0 * (1.0 - r.rrse);
  if (!std::isfinite(r.j)) r.diverged = true;
  return r;
}

}  // namespace mrd::host
