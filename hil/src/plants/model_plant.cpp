// An identified model as the plant (model_plant.hpp): the model file reader and the plant.
#include "mrd/hil/plants/model_plant.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <vector>

#include "mrd/common/input_file.hpp"

namespace mrd::hil {
namespace {

using nlohmann::json;

constexpr std::uint64_t kMaxModelBytes = std::uint64_t{64} << 20;  // [bytes]

struct SpecRegressor {
  std::string signal;
  Transform transform = Transform::kIdentity;
  double exponent = 1.0;
};

bool ParseTransform(const json& r, SpecRegressor* out, std::string* why) {
  static const std::map<std::string, std::pair<Transform, const char*>> kinds = {
      {"identity", {Transform::kIdentity, nullptr}}, {"abs_pow", {Transform::kAbsPow, "exponent"}},
      {"sign", {Transform::kSign, nullptr}},         {"low_pass", {Transform::kLowPass, "tau"}},
      {"tanh", {Transform::kTanh, "scale"}},         {"clip", {Transform::kClip, "limit"}}};
  const std::string name = r.value("transform", std::string("identity"));
  const auto it = kinds.find(name);
  if (it == kinds.end()) {
    *why = "unknown regressor transform '" + name + "'";
    return false;
  }
  out->transform = it->second.first;
  if (it->second.second != nullptr) out->exponent = r.at(it->second.second).get<double>();
  return true;
}

bool Parse(const json& j, int iteration, PlantModel* pm, std::string* why) {
  if (j.at("format").get<std::string>() != "mrd-sem-model") {
    *why = "not an mrd model file (format != mrd-sem-model)";
    return false;
  }
  if (j.at("version").get<int>() != 1) {
    *why = "unsupported model file version " + j.at("version").dump();
    return false;
  }
  const json& spec = j.at("spec");
  const std::string output = spec.at("output").get<std::string>();
  std::map<std::string, SpecRegressor> regs;  // by name
  std::vector<std::string> reg_order;         // spec order (host's regressor index)
  for (const json& r : spec.at("regressor")) {
    SpecRegressor sr;
    sr.signal = r.at("signal").get<std::string>();
    if (!ParseTransform(r, &sr, why)) return false;
    const std::string name = r.at("name").get<std::string>();
    regs[name] = sr;
    reg_order.push_back(name);
  }
  const int k = iteration >= 0 ? iteration : j.at("selected").get<int>();
  const json* it = nullptr;
  std::string have;
  for (const json& ji : j.at("iterations")) {
    const int n = ji.at("iteration").get<int>();
    have += (have.empty() ? "" : ", ") + std::to_string(n);
    if (n == k) it = &ji;
  }
  if (it == nullptr) {
    *why = "no iteration " + std::to_string(k) + " (the file has " + have + ")";
    return false;
  }
  pm->iteration = k;
  // Regressors the terms use, in spec order; channels: output first, then their signals.
  const json& terms = it->at("terms");
  std::vector<bool> used(reg_order.size(), false);
  for (const json& t : terms) {
    for (const json& f : t.at("factors")) {
      const std::string name = f.at("regressor").get<std::string>();
      const auto pos = std::find(reg_order.begin(), reg_order.end(), name);
      if (pos == reg_order.end()) {
        *why = "iteration " + std::to_string(k) + ": unknown regressor '" + name + "'";
        return false;
      }
      used[static_cast<std::size_t>(pos - reg_order.begin())] = true;
    }
  }
  std::vector<std::string> chans{output};
  std::vector<int> reg_index(reg_order.size(), -1);
  Model& m = pm->model;
  m = Model{};
  for (std::size_t i = 0; i < reg_order.size(); ++i) {
    if (!used[i]) continue;
    const SpecRegressor& r = regs[reg_order[i]];
    if (std::find(chans.begin(), chans.end(), r.signal) == chans.end()) chans.push_back(r.signal);
    if (m.num_regressors >= kMaxRegressors) {
      *why = "more than " + std::to_string(kMaxRegressors) + " regressors";
      return false;
    }
    reg_index[i] = m.num_regressors;
    auto& mr = m.regressors[m.num_regressors++];
    mr.channel =
        static_cast<std::uint8_t>(std::find(chans.begin(), chans.end(), r.signal) - chans.begin());
    mr.transform = r.transform;
    mr.exponent = r.exponent;
  }
  if (chans.size() > kMaxChannels) {
    *why = std::to_string(chans.size()) + " channels > capacity " + std::to_string(kMaxChannels);
    return false;
  }
  // The plant supplies v, x and E; the output is the force it reports.
  for (std::size_t c = 1; c < chans.size(); ++c) {
    if (chans[c] != "v" && chans[c] != "x" && chans[c] != "E") {
      *why = "iteration " + std::to_string(k) + " reads signal '" + chans[c] +
             "', which the plant cannot supply (it supplies v, x and E)";
      return false;
    }
  }
  if (std::find(chans.begin(), chans.end(), "E") == chans.end()) {
    *why = "iteration " + std::to_string(k) +
           " does not read the command 'E': the firmware could not act on this plant";
    return false;
  }
  m.num_channels = static_cast<std::uint8_t>(chans.size());
  m.output_channel = 0;
  pm->has_envelope = true;
  for (std::size_t c = 0; c < chans.size(); ++c) {
    if (chans[c].size() > kMaxNameLength) {
      *why = "channel name '" + chans[c] + "' too long";
      return false;
    }
    std::memcpy(m.channel_names[c].data(), chans[c].c_str(), chans[c].size() + 1);
    const json* ch = nullptr;
    for (const json& jc : j.at("channels")) {
      if (jc.at("name").get<std::string>() == chans[c]) ch = &jc;
    }
    if (ch == nullptr) {
      *why = "no channel '" + chans[c] + "' in 'channels'";
      return false;
    }
    m.scales[c] = {ch->at("offset").get<double>(), ch->at("scale").get<double>()};
    if (ch->contains("min") && ch->contains("max")) {
      pm->lo[c] = ch->at("min").get<double>();
      pm->hi[c] = ch->at("max").get<double>();
      if (!std::isfinite(pm->lo[c]) || !std::isfinite(pm->hi[c]) || pm->lo[c] > pm->hi[c]) {
        *why = "channel '" + chans[c] + "': bad envelope";
        return false;
      }
    } else {
      pm->has_envelope = false;
    }
  }
  pm->v = m.ChannelIndex("v");
  pm->x = m.ChannelIndex("x");
  pm->e = m.ChannelIndex("E");
  if (terms.size() > kMaxTerms) {
    *why = std::to_string(terms.size()) + " terms > capacity " + std::to_string(kMaxTerms);
    return false;
  }
  for (const json& t : terms) {
    Term& term = m.terms[m.num_terms];
    const json& factors = t.at("factors");
    if (factors.size() > kMaxFactors) {
      *why = "a term has more than " + std::to_string(kMaxFactors) + " factors";
      return false;
    }
    for (const json& f : factors) {
      const std::string name = f.at("regressor").get<std::string>();
      const auto i = std::find(reg_order.begin(), reg_order.end(), name) - reg_order.begin();
      const int delay = f.at("delay").get<int>(), power = f.at("power").get<int>();
      if (delay < 0 || delay > static_cast<int>(kMaxDelay) || power < 1 || power > kMaxPower) {
        *why = "factor '" + name + "': delay or power out of range";
        return false;
      }
      term.factors[term.num_factors++] = {
          static_cast<std::uint8_t>(reg_index[static_cast<std::size_t>(i)]),
          static_cast<std::uint8_t>(delay), static_cast<std::uint8_t>(power)};
    }
    m.coefficients[m.num_terms++] = t.at("coefficient").get<double>();
  }
  if (m.Validate() != Error::kOk) {
    *why = std::string("iteration ") + std::to_string(k) + " is not a valid model (" +
           ErrorName(m.Validate()) + ")";
    return false;
  }
  return true;
}

// value held to [lo, hi]; *held set when it was outside.
double Hold(double value, double lo, double hi, bool* held) {
  if (value < lo || value > hi) *held = true;
  return std::clamp(value, lo, hi);
}

}  // namespace

bool LoadPlantModel(const std::string& path, int iteration, double margin, PlantModel* out,
                    std::string* error) {
  std::string text;
  std::string read_error;
  if (!ReadInputFile(path, kMaxModelBytes, &text, &read_error)) {
    *error = read_error;
    return false;
  }
  PlantModel pm;
  pm.file = path;
  try {
    const json j = json::parse(text);
    std::string why;
    if (!Parse(j, iteration, &pm, &why)) {
      *error = path + ": " + why;
      return false;
    }
  } catch (const json::exception& e) {
    *error = path + ": bad model file: " + e.what();
    return false;
  }
  if (pm.has_envelope) {
    for (std::size_t c = 0; c < pm.model.num_channels; ++c) {
      const double m = margin * (pm.hi[c] - pm.lo[c]);
      pm.lo[c] -= m;
      pm.hi[c] += m;
    }
  }
  *out = std::move(pm);
  return true;
}

ModelPlant::ModelPlant(std::shared_ptr<const PlantModel> model, std::unique_ptr<Plant> motion)
    : pm_(std::move(model)), motion_(std::move(motion)), runner_(pm_->model) {
  Reset();
}

double ModelPlant::Force(ModelRunner* runner, const PlantSample& s, double volts, bool finish,
                         PlantHolds* holds) const {
  std::array<double, kMaxChannels> raw{};
  bool held = false;
  const auto set = [&](int c, double value) {
    if (c < 0) return;
    const auto i = static_cast<std::size_t>(c);
    raw[i] = pm_->has_envelope ? Hold(value, pm_->lo[i], pm_->hi[i], &held) : value;
  };
  set(pm_->v, s.v);
  set(pm_->x, s.x);
  set(pm_->e, volts);
  const std::span<const double> row(raw.data(), pm_->model.num_channels);
  runner->Begin(row);
  double f = runner->Evaluate();
  bool force_held = false;
  if (pm_->has_envelope) f = Hold(f, pm_->lo[0], pm_->hi[0], &force_held);
  if (finish) runner->Finish(f);
  if (holds != nullptr) {
    holds->input_holds += held ? 1 : 0;
    holds->force_holds += force_held ? 1 : 0;
  }
  return f;
}

void ModelPlant::Reset() {
  motion_->Reset();
  runner_.Reset();
  holds_ = {};
  // Sample 0: the model at the motion's first sample with the coil at 0 V.
  sample_ = motion_->Sample();
  sample_.force = Force(&runner_, sample_, 0.0, true, &holds_);
}

PlantSample ModelPlant::Step(double volts) {
  sample_ = motion_->Step(volts);
  sample_.force = Force(&runner_, sample_, volts, true, &holds_);
  return sample_;
}

PlantSample ModelPlant::Sample() const { return sample_; }

PlantSample ModelPlant::Probe(double volts) const {
  PlantSample s = motion_->Probe(volts);
  ModelRunner copy = runner_;  // value type: the history; no allocation
  s.force = Force(&copy, s, volts, false, nullptr);
  return s;
}

}  // namespace mrd::hil
