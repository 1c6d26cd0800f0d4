// IdentifyDefault (mrd/host/sem_default.hpp): the built-in specs identified in turn, the one
// that predicts unseen data best kept.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>

#include "mrd/host/default_spec.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/sem_default.hpp"

namespace mrd::host {
namespace {

using nlohmann::json;

constexpr double kInf = std::numeric_limits<double>::infinity();

enum class Rule { kValidation, kCrossValidation, kIdentification };

Rule RuleFor(std::span<const DataSet> identification, std::span<const DataSet> validation,
             const SemSpec& spec) {
  if (!validation.empty()) return Rule::kValidation;
  for (const DataSet& d : identification) {
    const std::size_t scored = d.rows() - std::min(d.rows(), std::size_t(spec.MaxDelay()));
    if (scored < kMinFoldSamples * static_cast<std::size_t>(kSelectionFolds)) {
      return Rule::kIdentification;
    }
  }
  return Rule::kCrossValidation;
}

std::string RuleText(Rule rule) {
  switch (rule) {
    case Rule::kValidation:
      return "lowest free-run RMSE of the selected model over the validation data";
    case Rule::kCrossValidation:
      return fmt::format(
          "lowest {}-fold cross-validated free-run RMSE of the selected structure inside the "
          "identification data (coefficients by least squares on the other folds)",
          kSelectionFolds);
    case Rule::kIdentification:
      return fmt::format(
          "lowest free-run RMSE of the selected model on the identification data (records too "
          "short for {}-fold cross-validation)",
          kSelectionFolds);
  }
  return {};
}

// RMSE [output unit] of the selected model of one spec's identification, every row alike.
double Score(Rule rule, const FamilyIdentification& fi, std::span<const DataSet> identification,
             std::span<const DataSet> validation) {
  SemSpec mse = fi.spec;
  mse.weighting = CostWeighting::kMse;
  const SemResult& r = fi.result;
  const SemIteration& sel =
      *std::find_if(r.iterations.begin(), r.iterations.end(),
                    [&](const SemIteration& it) { return it.iteration == r.selected; });
  // Costs are per-record means of the normalised squared error: averaged over records (and
  // folds), then back to the output's unit.
  double sum = 0.0;
  std::size_t parts = 0;
  switch (rule) {
    case Rule::kValidation:
    case Rule::kIdentification:
      for (const DataSet& d : rule == Rule::kValidation ? validation : identification) {
        sum += SimulateCost(mse, r.channels, sel.terms, sel.coefficients, d);
        ++parts;
      }
      break;
    case Rule::kCrossValidation:
      for (const double f :
           CrossValidatedCost(mse, r.channels, sel.terms, identification, kSelectionFolds)) {
        sum += f;
      }
      parts = identification.size() * static_cast<std::size_t>(kSelectionFolds);
      break;
  }
  const double rmse =
      std::sqrt(sum / static_cast<double>(std::max<std::size_t>(parts, 1))) * r.channels[0].scale;
  return std::isfinite(rmse) ? rmse : kInf;
}

}  // namespace

DefaultIdentification IdentifyDefault(std::span<const DataSet> identification,
                                      std::span<const DataSet> validation,
                                      const SemOptions& options, const FamilyProgress& member,
                                      const SpecProgress& progress) {
  DefaultIdentification out;
  const auto specs = BuiltInSemSpecs();
  double best = kInf;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const SemSpec spec = ParseSemSpec(specs[i].text, specs[i].name);
    const Rule rule = RuleFor(identification, validation, spec);
    if (i == 0) out.choice.rule = RuleText(rule);
    SpecCandidate c;
    c.name = specs[i].name;
    if (progress) progress(i, specs.size(), c, false);
    FamilyIdentification fi = IdentifyFamilies(spec, identification, validation, options, member);
    c.rmse = Score(rule, fi, identification, validation);
    c.selected = fi.result.selected;
    for (const auto& it : fi.result.iterations) {
      if (it.iteration == c.selected) c.terms = it.terms.size();
    }
    if (out.choice.chosen < 0 || c.rmse < best) {
      out.choice.chosen = static_cast<int>(i);
      best = c.rmse;
      out.identification = std::move(fi);
    }
    out.choice.specs.push_back(c);
    if (progress) progress(i, specs.size(), c, true);
  }
  return out;
}

json SpecChoiceToJson(const SpecChoice& c) {
  json specs = json::array();
  for (const auto& s : c.specs) {
    specs.push_back({{"name", s.name},
                     {"rmse", std::isfinite(s.rmse) ? json(s.rmse) : json(nullptr)},
                     {"selected", s.selected},
                     {"terms", s.terms}});
  }
  return {{"rule", c.rule}, {"chosen", c.chosen}, {"specs", specs}};
}

SpecChoice SpecChoiceFromJson(const json& j, const std::string& path) {
  auto bad = [&](const std::string& what) {
    return InputError(path, 0, fmt::format("spec_choice: {}", what));
  };
  auto field = [&](const json& obj, const char* key, const std::string& where) -> const json& {
    if (!obj.is_object() || !obj.contains(key)) throw bad(fmt::format("{} lacks '{}'", where, key));
    return obj.at(key);
  };
  auto count = [](const json& v) {  // an integer 0 ... 1e6 (not 1.5, not "2")
    return v.is_number_integer() && (v.is_number_unsigned() || v.get<long long>() >= 0) &&
           v.get<std::uint64_t>() <= 1000000;
  };
  SpecChoice c;
  const json& rule = field(j, "rule", "section");
  if (!rule.is_string()) throw bad("'rule' must be a string");
  c.rule = rule.get<std::string>();
  const json& specs = field(j, "specs", "section");
  if (!specs.is_array() || specs.empty()) throw bad("'specs' must be a non-empty array");
  for (const json& js : specs) {
    const std::string where = fmt::format("spec {}", c.specs.size());
    SpecCandidate s;
    const json& name = field(js, "name", where);
    if (!name.is_string()) throw bad(where + ": 'name' must be a string");
    s.name = name.get<std::string>();
    const json& rmse = field(js, "rmse", where);
    if (!rmse.is_null() && !rmse.is_number()) throw bad(where + ": 'rmse' must be a number");
    s.rmse = rmse.is_null() ? kInf : rmse.get<double>();
    const json& sel = field(js, "selected", where);
    const json& terms = field(js, "terms", where);
    if (!count(sel) || !count(terms)) {
      throw bad(where + ": 'selected' and 'terms' must be counts (integers 0 ... 1000000)");
    }
    s.selected = sel.get<int>();
    s.terms = terms.get<std::size_t>();
    c.specs.push_back(s);
  }
  const json& chosen = field(j, "chosen", "section");
  if (!chosen.is_number_integer() || chosen.get<long long>() < 0 ||
      chosen.get<long long>() >= static_cast<long long>(c.specs.size())) {
    throw bad(fmt::format("'chosen' must index 'specs' (0 ... {})", c.specs.size() - 1));
  }
  c.chosen = chosen.get<int>();
  return c;
}

std::string SpecProgressLine(std::size_t i, std::size_t n, const SpecCandidate& c, bool done) {
  return done
             ? fmt::format("built-in spec {}/{}: {}: selected iteration {} ({} terms), RMSE {:.6g}",
                           i + 1, n, c.name, c.selected, c.terms, c.rmse)
             : fmt::format("built-in spec {}/{}: {}", i + 1, n, c.name);
}

}  // namespace mrd::host
