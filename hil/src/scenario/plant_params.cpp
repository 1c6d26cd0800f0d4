#include "plant_params.hpp"

#include "mrd/common/input_file.hpp"
#include "mrd/params/spencer_params_file.hpp"

namespace mrd::hil {
namespace {
std::string At(const std::string& path, std::size_t line, const std::string& why) {
  std::string out = Printable(path);
  if (line > 0) out.append(":").append(std::to_string(line));
  out += ": ";
  out += Printable(why);
  return out;
}
}  // namespace

bool ResolvePlantDamper(const std::string& scenario_path, const toml::table& root,
                        const toml::table* overrides, Scenario* s, std::string* error) {
  SpencerParams p;
  if (!s->params_file.empty()) {
    params::ParamsError e;
    if (!params::LoadSpencerParamsFile(s->params_file, &p, &e)) {
      const toml::node* n = root.at_path("plant.params").node();
      *error = At(s->params_file, e.line, e.reason) + " (named at " + Printable(scenario_path) +
               ":" + std::to_string(n != nullptr ? n->source().begin.line : 0) + ")";
      return false;
    }
  } else if (!SpencerParams::FromPreset(s->preset, &p)) {
    const toml::node* n = root.at_path("plant.preset").node();
    *error = At(scenario_path, n != nullptr ? n->source().begin.line : 0,
                "unknown plant preset '" + s->preset + "' (paper, spencer1997)");
    return false;
  }
  s->plant_overrides = overrides != nullptr && !overrides->empty();
  if (overrides != nullptr) {
    for (const auto& [key, node] : *overrides) {
      const std::size_t line = node.source().begin.line;
      const std::string k(key.str());
      const auto v = node.value<double>();
      if (!v || node.is_boolean()) {
        *error = At(scenario_path, line, "'" + k + "' in [plant.spencer] must be a number");
        return false;
      }
      if (!params::SetSpencerField(&p, k, *v)) {
        *error = At(scenario_path, line,
                    "unknown key '" + k +
                        "' in [plant.spencer] (c0a c0b k0 c1a c1b k1 x0 "
                        "alpha_a alpha_b gamma beta A n eta)");
        return false;
      }
      std::string why;
      if (!params::CheckPhysical(p, &why)) {
        *error = At(scenario_path, line, why);
        return false;
      }
    }
  }
  std::string why;
  if (!params::CheckPhysical(p, &why)) {
    *error = At(s->params_file.empty() ? scenario_path : s->params_file, 0, why);
    return false;
  }
  s->damper = p;
  return true;
}

}  // namespace mrd::hil
