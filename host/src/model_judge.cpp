#include "mrd/host/model_judge.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace mrd::host {

std::string SignalUnit(const std::string& name) {
  static const std::map<std::string, std::string> kUnits = {
      {"t", "s"}, {"x", "cm"}, {"v", "cm/s"}, {"E", "V"}, {"f", "N"}};
  const auto it = kUnits.find(name);
  return it == kUnits.end() ? std::string() : it->second;
}

std::string WithUnit(double value, const std::string& name) {
  const std::string unit = SignalUnit(name);
  return unit.empty() ? fmt::format("{:.4g}", value) : fmt::format("{:.4g} {}", value, unit);
}

std::string CostWeightingName(const ModelFile& m) {
  const std::string& y = m.spec.output;
  if (m.spec.weighting == CostWeighting::kRelative) {
    return fmt::format("relative weighting 1/max(|{0}_n|, {1:g}) of normalised {0}", y,
                       m.spec.floor);
  }
  return fmt::format("unweighted MSE of normalised {}", y);
}

std::string CostWeightingShort(const ModelFile& m) {
  return m.spec.weighting == CostWeighting::kRelative ? fmt::format("rel, floor {:g}", m.spec.floor)
                                                      : std::string("mse");
}

std::vector<EnvelopeCheck> CheckEnvelope(const ModelFile& m, const DataSet& data) {
  std::vector<EnvelopeCheck> out;
  for (std::size_t c = 1; c < m.channels.size(); ++c) {
    const ChannelInfo& ch = m.channels[c];
    if (!ch.has_range || !data.Has(ch.name)) continue;
    const std::vector<double>& col = data.Column(ch.name);
    EnvelopeCheck e;
    e.channel = ch.name;
    e.unit = SignalUnit(ch.name);
    e.env_min = ch.min;
    e.env_max = ch.max;
    e.samples = col.size();
    if (!col.empty()) {
      const auto [lo, hi] = std::minmax_element(col.begin(), col.end());
      e.data_min = *lo;
      e.data_max = *hi;
    }
    for (const double x : col) {
      const double beyond = x < ch.min ? ch.min - x : (x > ch.max ? x - ch.max : 0.0);
      if (beyond > 0.0) {
        ++e.outside;
        if (beyond > e.largest_excursion) {
          e.largest_excursion = beyond;
          e.worst_value = x;
        }
      }
    }
    out.push_back(e);
  }
  return out;
}

std::vector<std::string> EnvelopeWarnings(const std::string& model_path,
                                          const std::string& data_path,
                                          const std::vector<EnvelopeCheck>& checks) {
  std::vector<std::string> lines;
  for (const EnvelopeCheck& e : checks) {
    if (e.outside == 0) continue;
    const std::string u = e.unit.empty() ? "" : " " + e.unit;
    lines.push_back(fmt::format(
        "warning: {} on {}: {} outside the identification envelope [{:.4g}, {:.4g}]{} in "
        "{:.1f} % of samples ({} of {}), largest excursion {:.4g}{} beyond ({} = {:.4g}{})",
        model_path, data_path, e.channel, e.env_min, e.env_max, u, 100.0 * e.outside_share(),
        e.outside, e.samples, e.largest_excursion, u, e.channel, e.worst_value, u));
  }
  return lines;
}

nlohmann::json EnvelopeJson(const std::vector<EnvelopeCheck>& checks) {
  nlohmann::json j = nlohmann::json::object();
  for (const EnvelopeCheck& e : checks) {
    j[e.channel] = {{"unit", e.unit},
                    {"envelope", {e.env_min, e.env_max}},
                    {"data", {e.data_min, e.data_max}},
                    {"samples", e.samples},
                    {"outside", e.outside},
                    {"outside_share", e.outside_share()},
                    {"largest_excursion", e.largest_excursion},
                    {"worst_value", e.worst_value}};
  }
  return j;
}

bool AnyOutside(const std::vector<EnvelopeCheck>& checks) {
  return std::any_of(checks.begin(), checks.end(),
                     [](const EnvelopeCheck& e) { return e.outside > 0; });
}

nlohmann::json MetricsJson(const ModelFile& m, const SimMetrics& s) {
  const std::string& y = m.spec.output;
  // Non-finite figures (a diverged run) become null in JSON.
  const auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  return {{"samples", s.samples},
          {"J", num(s.j)},
          {"J_weighting", CostWeightingName(m)},
          {"mse", num(s.mse)},
          {"rmse", num(s.rmse_physical)},
          {"rmse_unit", SignalUnit(y)},
          {"mse_physical", num(s.mse_physical)},
          {"rmse_physical", num(s.rmse_physical)},
          {"nrmse", num(s.rrse)},
          {"rrse", num(s.rrse)},
          {"fit_percent", num(s.fit_percent)},
          {"diverged", s.diverged}};
}

}  // namespace mrd::host
