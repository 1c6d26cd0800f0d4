#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>

#include "mrd/host/input_error.hpp"
#include "mrd/host/sem_family.hpp"

namespace mrd::host {
namespace {

using nlohmann::json;

constexpr double kInf = std::numeric_limits<double>::infinity();

struct TransformInfo {
  Transform transform;
  const char* name;
  const char* parameter;  // key of its parameter, "" when it takes none
};
constexpr TransformInfo kTransforms[] = {
    {Transform::kIdentity, "identity", ""}, {Transform::kAbsPow, "abs_pow", "exponent"},
    {Transform::kSign, "sign", ""},         {Transform::kLowPass, "low_pass", "tau"},
    {Transform::kTanh, "tanh", "scale"},    {Transform::kClip, "clip", "limit"},
};

const TransformInfo& Info(Transform t) {
  for (const auto& i : kTransforms) {
    if (i.transform == t) return i;
  }
  return kTransforms[0];
}

double Sum(const std::vector<double>& v) {
  double s = 0.0;
  for (const double x : v) s += x;
  return s;
}

std::size_t ScoredSamples(const SemSpec& spec, std::span<const DataSet> identification) {
  std::size_t n = 0;
  for (const DataSet& d : identification) {
    n += d.rows() - std::min(d.rows(), static_cast<std::size_t>(spec.MaxDelay()));
  }
  return n;
}

// Score of one run's selected iteration by `rule` (see the header).
enum class Rule { kValidation, kCrossValidation, kIdentification };

double Score(Rule rule, const SemSpec& spec, std::span<const DataSet> identification,
             const SemResult& r, const SemIteration& sel) {
  double s = kInf;
  switch (rule) {
    case Rule::kValidation:
      s = Sum(sel.validation_j);
      break;
    case Rule::kCrossValidation: {
      // A one-step pick's fold costs are no free-run J: recomputed so members compare alike.
      const double cv = Sum(
          sel.cv_j.size() == static_cast<std::size_t>(kSelectionFolds) && !r.cv_one_step
              ? sel.cv_j
              : CrossValidatedCost(spec, r.channels, sel.terms, identification, kSelectionFolds));
      s = CrossValidationScore(cv, sel.terms.size(), static_cast<double>(r.num_candidates),
                               static_cast<double>(ScoredSamples(spec, identification)));
      break;
    }
    case Rule::kIdentification:
      s = sel.j;
      break;
  }
  return std::isfinite(s) ? s : kInf;
}

const json& Field(const json& obj, const char* key, const std::string& path,
                  const std::string& where) {
  if (!obj.is_object() || !obj.contains(key)) {
    throw InputError(path, 0, fmt::format("family: {} lacks '{}'", where, key));
  }
  return obj.at(key);
}

}  // namespace

std::string TransformLabel(const TransformChoice& c) {
  const TransformInfo& i = Info(c.transform);
  if (*i.parameter == '\0') return i.name;
  return fmt::format("{}({}={:g})", i.name, i.parameter, c.parameter);
}

std::string FamilyMembers(const std::vector<std::string>& regressors, const FamilyCombination& c) {
  std::string s;
  for (std::size_t i = 0; i < c.members.size(); ++i) {
    s += fmt::format("{}{} = {}", i > 0 ? ", " : "",
                     i < regressors.size() ? regressors[i] : std::string("?"),
                     TransformLabel(c.members[i]));
  }
  return s;
}

std::string FamilyProgressLine(std::size_t i, std::size_t n,
                               const std::vector<std::string>& regressors,
                               const FamilyCombination& c) {
  return fmt::format("family {}/{}: {}: selected iteration {} ({} terms, J {:.6g}), score {:.6g}",
                     i + 1, n, FamilyMembers(regressors, c), c.selected, c.terms, c.j, c.score);
}

std::vector<std::vector<TransformChoice>> FamilyCombinations(const SemSpec& spec) {
  std::vector<std::vector<TransformChoice>> out{{}};
  for (const auto& r : spec.regressors) {
    if (r.family.empty()) continue;
    std::vector<std::vector<TransformChoice>> next;
    for (const auto& prefix : out) {
      for (const auto& m : r.family) {
        next.push_back(prefix);
        next.back().push_back(m);
      }
    }
    out = std::move(next);
  }
  return out;
}

SemSpec ResolveFamilies(const SemSpec& spec, const std::vector<TransformChoice>& choice) {
  SemSpec s = spec;
  std::size_t i = 0;
  for (auto& r : s.regressors) {
    if (r.family.empty()) continue;
    if (i >= choice.size()) throw InputError(spec.path, r.line, "family: too few members chosen");
    r.transform = choice[i].transform;
    r.exponent = choice[i].parameter;
    r.family.clear();
    ++i;
  }
  if (i != choice.size()) throw InputError(spec.path, 0, "family: too many members chosen");
  return s;
}

FamilyIdentification IdentifyFamilies(const SemSpec& spec, std::span<const DataSet> identification,
                                      std::span<const DataSet> validation,
                                      const SemOptions& options, const FamilyProgress& progress) {
  FamilyIdentification out;
  for (const auto& r : spec.regressors) {
    if (!r.family.empty()) out.family.regressors.push_back(r.name);
  }
  if (out.family.empty()) {
    out.spec = spec;
    out.result = Identify(spec, identification, validation, options);
    return out;
  }
  std::size_t shortest = std::numeric_limits<std::size_t>::max();
  for (const DataSet& d : identification) {
    shortest = std::min(shortest, d.rows() - std::min(d.rows(), std::size_t(spec.MaxDelay())));
  }
  const Rule rule = !validation.empty() ? Rule::kValidation
                    : shortest >= kMinFoldSamples * static_cast<std::size_t>(kSelectionFolds)
                        ? Rule::kCrossValidation
                        : Rule::kIdentification;
  switch (rule) {
    case Rule::kValidation:
      out.family.rule = "lowest summed validation J of the selected iteration";
      break;
    case Rule::kCrossValidation:
      out.family.rule = fmt::format(
          "lowest n ln(CV J) + m ln(n) + 2 ln(C choose m) of the selected iteration (CV J: its "
          "summed {}-fold cross-validated free-run J; m terms of C candidates; n scored samples)",
          kSelectionFolds);
      break;
    case Rule::kIdentification:
      out.family.rule = fmt::format(
          "lowest identification J of the selected iteration (records too short for {}-fold "
          "cross-validation)",
          kSelectionFolds);
      break;
  }
  const auto combos = FamilyCombinations(spec);
  double best = kInf;
  for (std::size_t c = 0; c < combos.size(); ++c) {
    SemSpec resolved = ResolveFamilies(spec, combos[c]);
    SemResult r = Identify(resolved, identification, validation, options);
    const auto it = std::find_if(r.iterations.begin(), r.iterations.end(),
                                 [&](const SemIteration& i) { return i.iteration == r.selected; });
    if (it == r.iterations.end()) throw InputError(spec.path, 0, "family: no selected iteration");
    const SemIteration& sel = *it;
    FamilyCombination fc;
    fc.members = combos[c];
    fc.score = Score(rule, resolved, identification, r, sel);
    fc.selected = r.selected;
    fc.terms = sel.terms.size();
    fc.j = sel.j;
    if (out.family.chosen < 0 || fc.score < best) {
      out.family.chosen = static_cast<int>(c);
      best = fc.score;
      out.spec = std::move(resolved);
      out.result = std::move(r);
    }
    out.family.combinations.push_back(fc);
    if (progress) progress(c, combos.size(), out.family.regressors, fc);
  }
  return out;
}

json FamilyToJson(const FamilyResult& f) {
  json combos = json::array();
  for (const auto& c : f.combinations) {
    json members = json::array();
    for (const auto& m : c.members) {
      const TransformInfo& i = Info(m.transform);
      json jm = {{"transform", i.name}};
      if (*i.parameter != '\0') jm[i.parameter] = m.parameter;
      members.push_back(jm);
    }
    combos.push_back({{"members", members},
                      {"score", std::isfinite(c.score) ? json(c.score) : json()},
                      {"selected", c.selected},
                      {"terms", c.terms},
                      {"J", c.j}});
  }
  return {{"regressors", f.regressors},
          {"rule", f.rule},
          {"chosen", f.chosen},
          {"combinations", combos}};
}

FamilyResult FamilyFromJson(const json& j, const SemSpec& spec, const std::string& path) {
  FamilyResult f;
  auto number = [&](const json& v, const std::string& what) {
    if (!v.is_number()) throw InputError(path, 0, fmt::format("family: {} must be a number", what));
    return v.get<double>();
  };
  const json& regs = Field(j, "regressors", path, "section");
  if (!regs.is_array() || regs.empty()) {
    throw InputError(path, 0, "family: 'regressors' must be a non-empty array of names");
  }
  for (const auto& r : regs) {
    if (!r.is_string()) throw InputError(path, 0, "family: 'regressors' must hold names");
    f.regressors.push_back(r.get<std::string>());
  }
  const json& rule = Field(j, "rule", path, "section");
  if (!rule.is_string()) throw InputError(path, 0, "family: 'rule' must be a string");
  f.rule = rule.get<std::string>();
  const json& combos = Field(j, "combinations", path, "section");
  if (!combos.is_array()) throw InputError(path, 0, "family: 'combinations' must be an array");
  for (const auto& jc : combos) {
    const std::string where = fmt::format("combination {}", f.combinations.size());
    FamilyCombination c;
    const json& members = Field(jc, "members", path, where);
    if (!members.is_array() || members.size() != f.regressors.size()) {
      throw InputError(path, 0,
                       fmt::format("family: {}: 'members' must hold one transform per "
                                   "family regressor ({})",
                                   where, f.regressors.size()));
    }
    for (const auto& jm : members) {
      const json& name = Field(jm, "transform", path, where);
      const TransformInfo* info = nullptr;
      for (const auto& i : kTransforms) {
        if (name.is_string() && name.get<std::string>() == i.name) info = &i;
      }
      if (info == nullptr) {
        throw InputError(path, 0,
                         fmt::format("family: {}: unknown transform {}", where, name.dump()));
      }
      TransformChoice m;
      m.transform = info->transform;
      if (*info->parameter != '\0') {
        m.parameter = number(Field(jm, info->parameter, path, where), where + " parameter");
      }
      c.members.push_back(m);
    }
    const json& score = Field(jc, "score", path, where);
    c.score = score.is_null() ? kInf : number(score, where + " score");
    const json& sel = Field(jc, "selected", path, where);
    const json& terms = Field(jc, "terms", path, where);
    auto count = [](const json& v) {  // an integer 0 ... 1e6 (not 1.5, not "2")
      return v.is_number_integer() && (v.is_number_unsigned() || v.get<long long>() >= 0) &&
             v.get<std::uint64_t>() <= 1000000;
    };
    if (!count(sel) || !count(terms)) {
      throw InputError(path, 0,
                       fmt::format("family: {}: 'selected' and 'terms' must be "
                                   "integers 0 ... 1000000",
                                   where));
    }
    c.selected = sel.get<int>();
    c.terms = terms.get<std::size_t>();
    const json& jj = Field(jc, "J", path, where);
    c.j = jj.is_null() ? kInf : number(jj, where + " J");
    f.combinations.push_back(c);
  }
  const json& chosen = Field(j, "chosen", path, "section");
  if (!chosen.is_number_integer() || chosen.get<long long>() < 0 ||
      chosen.get<long long>() >= static_cast<long long>(f.combinations.size())) {
    throw InputError(
        path, 0, fmt::format("family: 'chosen' = {} is not a combination index", chosen.dump()));
  }
  f.chosen = chosen.get<int>();
  // The spec holds the chosen members.
  const auto& members = f.combinations[static_cast<std::size_t>(f.chosen)].members;
  for (std::size_t i = 0; i < f.regressors.size(); ++i) {
    const int r = spec.RegressorIndex(f.regressors[i]);
    if (r < 0) {
      throw InputError(path, 0,
                       fmt::format("family: '{}' is not a regressor of the spec", f.regressors[i]));
    }
    const auto& reg = spec.regressors[static_cast<std::size_t>(r)];
    const TransformChoice held{reg.transform, reg.exponent, 0};
    if (!(held == members[i]) &&
        !(Info(reg.transform).parameter[0] == '\0' && reg.transform == members[i].transform)) {
      throw InputError(
          path, 0,
          fmt::format("family: the chosen {} of '{}' is not the spec's {}",
                      TransformLabel(members[i]), f.regressors[i], TransformLabel(held)));
    }
  }
  return f;
}

}  // namespace mrd::host
