#include "mrd/host/candidate_spec.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "mrd/host/input_error.hpp"
#include "spec_table.hpp"

namespace mrd::host {
namespace {

std::size_t LineOf(const toml::node& n) { return n.source().begin.line; }

[[noreturn]] void Fail(const std::string& path, const toml::node& n, const std::string& reason) {
  throw InputError(path, LineOf(n), reason);
}

std::string GetString(const std::string& path, const toml::node& n, const std::string& key) {
  const auto v = n.value<std::string>();
  if (!v) Fail(path, n, fmt::format("'{}' must be a string", key));
  return *v;
}

double GetNumber(const std::string& path, const toml::node& n, const std::string& key) {
  const auto v = n.value<double>();
  if (!v || !std::isfinite(*v)) Fail(path, n, fmt::format("'{}' must be a finite number", key));
  return *v;
}

int GetInt(const std::string& path, const toml::node& n, const std::string& key, int lo, int hi) {
  const auto* i = n.as_integer();
  if (i == nullptr) Fail(path, n, fmt::format("'{}' must be an integer", key));
  const auto v = i->get();
  if (v < lo || v > hi) {
    Fail(path, n, fmt::format("'{}' = {} out of range {} ... {}", key, v, lo, hi));
  }
  return static_cast<int>(v);
}

bool GetBool(const std::string& path, const toml::node& n, const std::string& key) {
  const auto v = n.value<bool>();
  if (!v || !n.is_boolean()) Fail(path, n, fmt::format("'{}' must be true or false", key));
  return *v;
}

// Integer list (a single integer is accepted as a list of one).
std::vector<int> GetIntList(const std::string& path, const toml::node& n, const std::string& key,
                            int lo, int hi, const std::string& what) {
  std::vector<int> out;
  auto one = [&](const toml::node& e) {
    const auto* i = e.as_integer();
    if (i == nullptr) {
      Fail(path, e, fmt::format("bad {} in '{}': must be an integer", what, key));
    }
    const auto v = i->get();
    if (v < lo || v > hi) {
      Fail(path, e, fmt::format("bad {} {} in '{}': must be {} ... {}", what, v, key, lo, hi));
    }
    out.push_back(static_cast<int>(v));
  };
  if (const auto* arr = n.as_array()) {
    for (const auto& e : *arr) one(e);
  } else {
    one(n);
  }
  if (out.empty()) Fail(path, n, fmt::format("'{}' must not be empty", key));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Transform ParseTransformName(const std::string& path, const toml::node& node) {
  const std::string tr = GetString(path, node, "transform");
  if (tr == "identity") return Transform::kIdentity;
  if (tr == "abs_pow") return Transform::kAbsPow;
  if (tr == "sign") return Transform::kSign;
  if (tr == "low_pass") return Transform::kLowPass;
  if (tr == "tanh") return Transform::kTanh;
  if (tr == "clip") return Transform::kClip;
  Fail(path, node,
       fmt::format("unknown transform '{}' (expected identity, abs_pow, sign, low_pass, tanh or "
                   "clip)",
                   tr));
}

// Key of a transform's parameter ("" when it takes none).
const char* ParameterKey(Transform t) {
  switch (t) {
    case Transform::kAbsPow:
      return "exponent";
    case Transform::kLowPass:
      return "tau";
    case Transform::kTanh:
      return "scale";
    case Transform::kClip:
      return "limit";
    case Transform::kIdentity:
    case Transform::kSign:
      break;
  }
  return "";
}

// One member of 'family': an inline table {transform = "...", <its parameter> = x}.
TransformChoice ParseFamilyMember(const std::string& path, const toml::node& node) {
  const auto* t = node.as_table();
  if (t == nullptr) {
    Fail(path, node,
         "'family' members must be inline tables like {transform = \"tanh\", "
         "scale = 0.1}");
  }
  TransformChoice c;
  c.line = LineOf(node);
  const toml::node* tr = t->get("transform");
  if (tr == nullptr) Fail(path, node, "'family' member needs a 'transform'");
  c.transform = ParseTransformName(path, *tr);
  const std::string want = ParameterKey(c.transform);
  bool has_parameter = false;
  for (const auto& [key, n] : *t) {
    const std::string k(key.str());
    if (k == "transform") continue;
    if (k != "exponent" && k != "tau" && k != "scale" && k != "limit") {
      Fail(path, n, fmt::format("unknown key '{}' in a 'family' member", k));
    }
    if (k != want) {
      Fail(path, n,
           fmt::format("'{}' is not a parameter of transform \"{}\" in 'family'", k,
                       GetString(path, *tr, "transform")));
    }
    c.parameter = GetNumber(path, n, k);
    if (!(c.parameter > 0.0) || (k == "tau" && c.parameter > kMaxLowPassTau)) {
      Fail(path, n,
           k == "tau"
               ? fmt::format("'tau' in 'family' must be in (0, {:g}] samples", kMaxLowPassTau)
               : fmt::format("'{}' in 'family' must be > 0", k));
    }
    has_parameter = true;
  }
  if (!want.empty() && !has_parameter) {
    Fail(path, node,
         fmt::format("'family' member \"{}\" needs '{}'", GetString(path, *tr, "transform"), want));
  }
  return c;
}

std::vector<TransformChoice> ParseFamily(const std::string& path, const toml::node& node) {
  const auto* arr = node.as_array();
  if (arr == nullptr) Fail(path, node, "'family' must be an array of inline tables");
  if (arr->empty()) Fail(path, node, "'family' must not be empty");
  std::vector<TransformChoice> out;
  for (const auto& e : *arr) {
    const TransformChoice c = ParseFamilyMember(path, e);
    if (std::find(out.begin(), out.end(), c) != out.end()) {
      Fail(path, e, "duplicate member in 'family'");
    }
    out.push_back(c);
  }
  return out;
}

ElementaryRegressor ParseRegressor(const std::string& path, const toml::table& t,
                                   std::size_t line) {
  ElementaryRegressor r;
  r.line = line;
  bool has_exponent = false;
  bool has_tau = false;
  bool has_scale = false;
  bool has_limit = false;
  bool has_transform = false;
  for (const auto& [key, node] : t) {
    const std::string k(key.str());
    if (k == "name") {
      r.name = GetString(path, node, k);
    } else if (k == "signal") {
      r.signal = GetString(path, node, k);
      r.signal_line = LineOf(node);
    } else if (k == "transform") {
      r.transform = ParseTransformName(path, node);
      has_transform = true;
    } else if (k == "family") {
      r.family = ParseFamily(path, node);
    } else if (k == "exponent") {
      r.exponent = GetNumber(path, node, k);
      if (!(r.exponent > 0.0)) Fail(path, node, "'exponent' must be > 0");
      has_exponent = true;
    } else if (k == "tau") {
      r.exponent = GetNumber(path, node, k);
      if (!(r.exponent > 0.0) || r.exponent > kMaxLowPassTau) {
        Fail(path, node, fmt::format("'tau' must be in (0, {:g}] samples", kMaxLowPassTau));
      }
      has_tau = true;
    } else if (k == "scale" || k == "limit") {
      r.exponent = GetNumber(path, node, k);
      if (!(r.exponent > 0.0) || !std::isfinite(r.exponent)) {
        Fail(path, node, fmt::format("'{}' must be a finite number > 0", k));
      }
      (k == "scale" ? has_scale : has_limit) = true;
    } else if (k == "powers") {
      r.powers = GetIntList(path, node, k, 1, kMaxPower, "power");
    } else if (k == "delays") {
      r.delays = GetIntList(path, node, k, 0, static_cast<int>(kMaxDelay), "delay");
    } else {
      Fail(path, node, fmt::format("unknown key '{}' in [[regressor]]", k));
    }
  }
  if (r.name.empty()) throw InputError(path, line, "[[regressor]] needs a non-empty 'name'");
  for (char c : r.name) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) {
      throw InputError(path, line,
                       fmt::format("regressor name '{}': use letters, digits and _ only", r.name));
    }
  }
  if (r.signal.empty()) throw InputError(path, line, "[[regressor]] needs a 'signal' column");
  if (r.powers.empty()) throw InputError(path, line, "[[regressor]] needs 'powers'");
  if (r.delays.empty()) r.delays = {0};
  if (!r.family.empty()) {
    if (has_transform || has_exponent || has_tau || has_scale || has_limit) {
      throw InputError(path, line,
                       "'family' replaces 'transform' and its parameter: give one or the other");
    }
    r.transform = r.family.front().transform;  // until ResolveFamilies picks a member
    r.exponent = r.family.front().parameter;
    return r;
  }
  if (has_exponent && r.transform != Transform::kAbsPow) {
    throw InputError(path, line, "'exponent' is only valid with transform = \"abs_pow\"");
  }
  if (r.transform == Transform::kAbsPow && !has_exponent) {
    throw InputError(path, line, "transform \"abs_pow\" needs an 'exponent'");
  }
  if (has_tau && r.transform != Transform::kLowPass) {
    throw InputError(path, line, "'tau' is only valid with transform = \"low_pass\"");
  }
  if (r.transform == Transform::kLowPass && !has_tau) {
    throw InputError(path, line, "transform \"low_pass\" needs 'tau' (time constant [samples])");
  }
  if (has_scale != (r.transform == Transform::kTanh)) {
    throw InputError(path, line,
                     has_scale ? "'scale' is only valid with transform = \"tanh\""
                               : "transform \"tanh\" needs 'scale' (> 0)");
  }
  if (has_limit != (r.transform == Transform::kClip)) {
    throw InputError(path, line,
                     has_limit ? "'limit' is only valid with transform = \"clip\""
                               : "transform \"clip\" needs 'limit' (> 0)");
  }
  return r;
}

StressSpec ParseStress(const std::string& path, const toml::node& node) {
  const auto* t = node.as_table();
  if (t == nullptr) Fail(path, node, "'stress' must be a table");
  StressSpec st;
  st.enabled = true;
  st.line = LineOf(node);
  auto names = [&](const toml::node& n, const std::string& key) {
    const auto* arr = n.as_array();
    if (arr == nullptr) Fail(path, n, fmt::format("'{}' must be an array of signal names", key));
    std::vector<std::string> out;
    for (const auto& e : *arr) out.push_back(GetString(path, e, key));
    return out;
  };
  for (const auto& [skey, sn] : *t) {
    const std::string sk(skey.str());
    if (sk == "stretch") {
      st.stretch = GetNumber(path, sn, sk);
      if (!(st.stretch >= 1.0) || st.stretch > 1e6) Fail(path, sn, "'stretch' must be in [1, 1e6]");
    } else if (sk == "stretch_signals") {
      st.stretch_signals = names(sn, sk);
    } else if (sk == "sweep_signals") {
      st.sweep_signals = names(sn, sk);
    } else if (sk == "sweep_period") {
      st.sweep_period = GetInt(path, sn, sk, 2, 100000000);
    } else if (sk == "hold") {
      st.hold = GetInt(path, sn, sk, 0, 100000000);
    } else if (sk == "rest") {
      st.rest = GetInt(path, sn, sk, 0, 100000000);
    } else if (sk == "force_bound") {
      st.force_bound = GetNumber(path, sn, sk);
      if (!(st.force_bound > 0.0) || !std::isfinite(st.force_bound)) {
        Fail(path, sn, "'force_bound' must be a finite number > 0");
      }
    } else {
      Fail(path, sn, fmt::format("unknown key '{}' in [stress]", sk));
    }
  }
  return st;
}

}  // namespace

int SemSpec::RegressorIndex(const std::string& name) const {
  for (std::size_t i = 0; i < regressors.size(); ++i) {
    if (regressors[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

int SemSpec::MaxDelay() const {
  int d = 0;
  for (const auto& r : regressors) d = std::max(d, r.delays.back());
  return d;
}

std::vector<std::string> SemSpec::Signals() const {
  std::vector<std::string> s{output};
  for (const auto& r : regressors) {
    if (std::find(s.begin(), s.end(), r.signal) == s.end()) s.push_back(r.signal);
  }
  return s;
}

namespace {

// [limits] key sk; false: not a key of [limits].
bool ParseLimitsKey(const std::string& path, const std::string& sk, const toml::node& sn,
                    SemSpec& s) {
  if (sk == "max_factors") {
    s.max_factors = GetInt(path, sn, sk, 1, static_cast<int>(kMaxFactors) * 4);
  } else if (sk == "max_degree") {
    s.max_degree = GetInt(path, sn, sk, 0, 1000);
  } else if (sk == "max_candidates") {
    s.max_candidates = GetInt(path, sn, sk, 1, 2000000000);
  } else if (sk == "constant") {
    s.constant = GetBool(path, sn, sk);
  } else {
    return false;
  }
  return true;
}

// [cost] key sk; false: not a key of [cost].
bool ParseCostKey(const std::string& path, const std::string& sk, const toml::node& sn,
                  SemSpec& s) {
  if (sk == "weighting") {
    const std::string w = GetString(path, sn, sk);
    if (w == "relative") {
      s.weighting = CostWeighting::kRelative;
    } else if (w == "mse") {
      s.weighting = CostWeighting::kMse;
    } else {
      Fail(path, sn, fmt::format("unknown weighting '{}' (expected relative or mse)", w));
    }
  } else if (sk == "floor") {
    s.floor = GetNumber(path, sn, sk);
    if (!(s.floor > 0.0)) Fail(path, sn, "'floor' must be > 0");
  } else {
    return false;
  }
  return true;
}

// [algorithm] keys of the model selection; false: not one of them.
bool ParseSelectionKey(const std::string& path, const std::string& sk, const toml::node& sn,
                       SemSpec& s) {
  if (sk == "selection") {
    const std::string se = GetString(path, sn, sk);
    if (se == "cross_validation") {
      s.selection = Selection::kCrossValidation;
    } else if (se == "tolerance") {
      s.selection = Selection::kTolerance;
    } else {
      Fail(path, sn,
           fmt::format("unknown selection '{}' (expected cross_validation or tolerance)", se));
    }
  } else if (sk == "selection_tolerance_percent") {
    s.selection_tolerance_percent = GetNumber(path, sn, sk);
    if (s.selection_tolerance_percent < 0.0) {
      Fail(path, sn, "'selection_tolerance_percent' must be >= 0");
    }
  } else if (sk == "selection_noise") {
    const std::string sn_value = GetString(path, sn, sk);
    if (sn_value == "auto") {
      s.selection_noise = SelectionNoise::kAuto;
    } else if (sn_value == "output") {
      s.selection_noise = SelectionNoise::kOutput;
    } else if (sn_value == "equation") {
      s.selection_noise = SelectionNoise::kEquation;
    } else {
      Fail(path, sn,
           fmt::format("unknown selection_noise '{}' (expected auto, output or equation)",
                       sn_value));
    }
  } else if (sk == "drop_terms") {
    s.drop_terms = GetBool(path, sn, sk);
  } else if (sk == "score_exchange") {
    s.score_exchange = GetBool(path, sn, sk);
  } else {
    return false;
  }
  return true;
}

// [algorithm] keys of the search; false: not one of them.
bool ParseSearchKey(const std::string& path, const std::string& sk, const toml::node& sn,
                    SemSpec& s) {
  if (sk == "strategy") {
    const std::string st = GetString(path, sn, sk);
    if (st == "best") {
      s.strategy = Strategy::kBest;
    } else if (st == "first") {
      s.strategy = Strategy::kFirst;
    } else {
      Fail(path, sn, fmt::format("unknown strategy '{}' (expected best or first)", st));
    }
  } else if (sk == "threshold_percent") {
    s.threshold_percent = GetNumber(path, sn, sk);
    if (s.threshold_percent < 0.0 || s.threshold_percent >= 100.0) {
      Fail(path, sn, "'threshold_percent' must be in [0, 100)");
    }
  } else if (sk == "max_iterations") {
    s.max_iterations = GetInt(path, sn, sk, 0, 100000);
  } else if (sk == "target_j") {
    s.target_j = GetNumber(path, sn, sk);
  } else if (sk == "divergence_limit") {
    s.divergence_limit = GetNumber(path, sn, sk);
    if (!(s.divergence_limit > 0.0)) Fail(path, sn, "'divergence_limit' must be > 0");
  } else if (sk == "exchange") {
    s.exchange = GetBool(path, sn, sk);
  } else if (sk == "one_step_start") {
    s.one_step_start = GetBool(path, sn, sk);
  } else if (sk == "refine") {
    s.refine = GetBool(path, sn, sk);
  } else if (sk == "monotone_in") {
    s.monotone_in = GetString(path, sn, sk);
    s.monotone_line = LineOf(sn);
    if (s.monotone_in.empty()) Fail(path, sn, "'monotone_in' must name an input signal");
  } else if (sk == "initial") {
    const auto* arr = sn.as_array();
    if (arr == nullptr) Fail(path, sn, "'initial' must be an array of term strings");
    for (const auto& e : *arr) s.initial.push_back(GetString(path, e, sk));
  } else {
    return false;
  }
  return true;
}

// The table [k] (limits, cost or algorithm), key by key.
void ParseSection(const std::string& path, const std::string& k, const toml::node& node,
                  SemSpec& s) {
  const auto* t = node.as_table();
  if (t == nullptr) Fail(path, node, fmt::format("'{}' must be a table", k));
  for (const auto& [skey, sn] : *t) {
    const std::string sk(skey.str());
    const bool known = k == "limits" ? ParseLimitsKey(path, sk, sn, s)
                       : k == "cost"
                           ? ParseCostKey(path, sk, sn, s)
                           : ParseSelectionKey(path, sk, sn, s) || ParseSearchKey(path, sk, sn, s);
    if (!known) Fail(path, sn, fmt::format("unknown key '{}' in [{}]", sk, k));
  }
}

// Regressor names unique; output regressors delayed, without family or low-pass.
void CheckRegressors(const std::string& path, const SemSpec& s) {
  for (std::size_t i = 0; i < s.regressors.size(); ++i) {
    const auto& r = s.regressors[i];
    for (std::size_t j = 0; j < i; ++j) {
      if (s.regressors[j].name == r.name) {
        throw InputError(path, r.line, fmt::format("duplicate regressor name '{}'", r.name));
      }
    }
    if (r.signal == s.output && r.delays.front() < 1) {
      throw InputError(path, r.line,
                       fmt::format("regressor '{}' reads the output '{}' at delay 0: output "
                                   "regressors need delays >= 1",
                                   r.name, s.output));
    }
    if (r.signal == s.output && !r.family.empty()) {
      throw InputError(path, r.line,
                       fmt::format("regressor '{}': 'family' is for input signals only, not the "
                                   "output '{}'",
                                   r.name, s.output));
    }
    if (r.signal == s.output && r.transform == Transform::kLowPass) {
      throw InputError(path, r.line,
                       fmt::format("regressor '{}': low_pass is for input signals only, not the "
                                   "output '{}'",
                                   r.name, s.output));
    }
  }
}

// At most kMaxFamilyCombinations family combinations; [stress] names input signals only.
void CheckFamiliesAndStress(const std::string& path, const SemSpec& s) {
  std::size_t combinations = 1;
  for (const auto& r : s.regressors) {
    combinations *= std::max<std::size_t>(r.family.size(), 1);
    if (combinations > kMaxFamilyCombinations) {
      throw InputError(path, r.line,
                       fmt::format("'family' regressors up to '{}' make {} combinations > {} "
                                   "(one identification each): use fewer members",
                                   r.name, combinations, kMaxFamilyCombinations));
    }
  }
  for (const auto* list : {&s.stress.stretch_signals, &s.stress.sweep_signals}) {
    for (const auto& name : *list) {
      const auto sig = s.Signals();
      if (name == s.output || std::find(sig.begin(), sig.end(), name) == sig.end()) {
        throw InputError(path, s.stress.line,
                         fmt::format("[stress]: '{}' is not an input signal of the spec", name));
      }
    }
  }
}

}  // namespace

SemSpec ParseSemSpec(const std::string& text, const std::string& path) {
  toml::table tbl;
  try {
    tbl = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw InputError(path, e.source().begin.line, std::string(e.description()));
  }
  return SemSpecFromTable(tbl, path);
}

SemSpec SemSpecFromTable(const toml::table& tbl, const std::string& path) {
  SemSpec s;
  s.path = path;
  for (const auto& [key, node] : tbl) {
    const std::string k(key.str());
    if (k == "output") {
      s.output = GetString(path, node, k);
      s.output_line = LineOf(node);
    } else if (k == "regressor") {
      const auto* arr = node.as_array();
      if (arr == nullptr || !arr->is_array_of_tables()) {
        Fail(path, node, "'regressor' must be an array of tables ([[regressor]])");
      }
      for (const auto& e : *arr) {
        s.regressors.push_back(ParseRegressor(path, *e.as_table(), LineOf(e)));
      }
    } else if (k == "limits" || k == "cost" || k == "algorithm") {
      ParseSection(path, k, node, s);
    } else if (k == "stress") {
      s.stress = ParseStress(path, node);
    } else {
      Fail(path, node, fmt::format("unknown key '{}'", k));
    }
  }
  if (s.output.empty()) throw InputError(path, 0, "missing 'output' (the signal to model)");
  if (s.regressors.empty()) throw InputError(path, 0, "no [[regressor]] given");
  CheckRegressors(path, s);
  CheckFamiliesAndStress(path, s);
  if (!s.monotone_in.empty()) {
    const auto sig = s.Signals();
    if (s.monotone_in == s.output ||
        std::find(sig.begin(), sig.end(), s.monotone_in) == sig.end()) {
      throw InputError(
          path, s.monotone_line,
          fmt::format("'monotone_in' = '{}' is not an input signal of the spec", s.monotone_in));
    }
  }
  // Initial terms are checked here so that errors name the spec.
  for (const auto& t : s.initial) ParseTerm(s, t, path, 0);
  return s;
}

SemSpec LoadSemSpec(const std::string& path) {
  return ParseSemSpec(ReadInputText(path, kMaxSpecFileBytes), path);
}

std::string TermName(const SemSpec& spec, const SemTerm& term) {
  if (term.factors.empty()) return "1";
  std::string s;
  for (const auto& f : term.factors) {
    if (!s.empty()) s += '*';
    s += spec.regressors[f.regressor].name;
    s += f.delay == 0 ? std::string("(k)") : fmt::format("(k-{})", f.delay);
    if (f.power != 1) s += fmt::format("^{}", f.power);
  }
  return s;
}

SemTerm ParseTerm(const SemSpec& spec, const std::string& text, const std::string& file,
                  std::size_t line) {
  std::string t;
  for (char c : text) {
    if (c != ' ' && c != '\t') t += c;
  }
  auto bad = [&](const std::string& why) -> InputError {
    return InputError(file, line, fmt::format("bad term '{}': {}", text, why));
  };
  SemTerm term;
  if (t == "1") return term;
  if (t.empty()) throw bad("empty");
  std::size_t pos = 0;
  while (pos <= t.size()) {
    const std::size_t star = t.find('*', pos);
    const std::string f = t.substr(pos, star == std::string::npos ? std::string::npos : star - pos);
    const std::size_t open = f.find('(');
    const std::size_t close = f.find(')');
    if (open == std::string::npos || close == std::string::npos || close < open) {
      throw bad("expected NAME(k-D)^P factors joined by *");
    }
    const std::string name = f.substr(0, open);
    const int r = spec.RegressorIndex(name);
    if (r < 0) throw bad(fmt::format("unknown regressor '{}'", name));
    const std::string arg = f.substr(open + 1, close - open - 1);
    int delay = 0;
    if (arg != "k") {
      if (arg.rfind("k-", 0) != 0) throw bad("delay must be written k or k-D");
      try {
        std::size_t used = 0;
        delay = std::stoi(arg.substr(2), &used);
        if (used != arg.size() - 2) throw bad("bad delay");
      } catch (const std::logic_error&) {
        throw bad("bad delay");
      }
    }
    int power = 1;
    const std::string rest = f.substr(close + 1);
    if (!rest.empty()) {
      if (rest[0] != '^') throw bad("expected ^P after the delay");
      try {
        std::size_t used = 0;
        power = std::stoi(rest.substr(1), &used);
        if (used != rest.size() - 1) throw bad("bad power");
      } catch (const std::logic_error&) {
        throw bad("bad power");
      }
    }
    const auto& reg = spec.regressors[r];
    if (std::find(reg.delays.begin(), reg.delays.end(), delay) == reg.delays.end()) {
      throw bad(fmt::format("delay {} not offered for '{}'", delay, name));
    }
    if (power < 1 || power > kMaxPower) throw bad(fmt::format("power {} out of range", power));
    bool merged = false;
    for (auto& g : term.factors) {
      if (g.regressor == r && g.delay == delay) {
        // A repeated factor multiplies: the total power must stay within the limit.
        g.power += power;
        if (g.power > kMaxPower) throw bad(fmt::format("power {} out of range", g.power));
        merged = true;
      }
    }
    if (!merged) term.factors.push_back({r, delay, power});
    if (star == std::string::npos) break;
    pos = star + 1;
  }
  // Powers (after merging repeated factors) must be among the regressor's offered powers.
  for (const auto& g : term.factors) {
    const auto& reg = spec.regressors[static_cast<std::size_t>(g.regressor)];
    if (std::find(reg.powers.begin(), reg.powers.end(), g.power) == reg.powers.end()) {
      throw bad(fmt::format("power {} not offered for '{}'", g.power, reg.name));
    }
  }
  std::sort(term.factors.begin(), term.factors.end(), [](const SemFactor& a, const SemFactor& b) {
    return a.regressor != b.regressor ? a.regressor < b.regressor : a.delay < b.delay;
  });
  return term;
}

std::string TermKey(const SemSpec& spec, const SemTerm& term) {
  // (signal, delay) -> (parity, exponent of |s|)
  std::map<std::pair<std::string, int>, std::pair<int, double>> m;
  for (const auto& f : term.factors) {
    const auto& r = spec.regressors[f.regressor];
    // A low-pass regressor is a signal of its own (one per time constant).
    // So is a saturating one (one per scale / limit).
    std::string sig = r.signal;
    if (r.transform == Transform::kLowPass) sig = fmt::format("{}~lp{:.9g}", r.signal, r.exponent);
    if (r.transform == Transform::kTanh) sig = fmt::format("{}~tanh{:.9g}", r.signal, r.exponent);
    if (r.transform == Transform::kClip) sig = fmt::format("{}~clip{:.9g}", r.signal, r.exponent);
    auto& e = m[{sig, f.delay}];
    switch (r.transform) {
      case Transform::kIdentity:
        e.first += f.power;
        e.second += f.power;
        break;
      case Transform::kAbsPow:
        e.second += r.exponent * f.power;
        break;
      case Transform::kSign:
        e.first += f.power;
        break;
      case Transform::kLowPass:
      case Transform::kTanh:
      case Transform::kClip:
        e.first += f.power;
        e.second += f.power;
        break;
    }
  }
  std::string key;
  for (const auto& [sd, pe] : m) {
    const int parity = pe.first % 2;
    const long long ex = std::llround(pe.second * 1e9);
    if (parity == 0 && ex == 0) continue;  // factor is 1
    key += fmt::format("{}@{}:{}:{};", sd.first, sd.second, parity, ex);
  }
  return key;
}

std::int64_t CountCandidateCombinations(const SemSpec& spec) {
  constexpr std::int64_t kCap = std::int64_t{1} << 62;
  auto add = [](std::int64_t a, std::int64_t b) { return a > kCap - b ? kCap : a + b; };
  // ways[f][d]: combinations with f factors and summed power d (d capped by max_degree; with
  // no degree limit all degrees share d = 0).
  const int dmax = spec.max_degree > 0 ? spec.max_degree : 0;
  std::vector<std::vector<std::int64_t>> ways(
      static_cast<std::size_t>(spec.max_factors) + 1,
      std::vector<std::int64_t>(static_cast<std::size_t>(dmax) + 1, 0));
  ways[0][0] = 1;
  for (const auto& r : spec.regressors) {
    for (std::size_t slot = 0; slot < r.delays.size(); ++slot) {
      auto next = ways;
      for (std::size_t f = 0; f + 1 < ways.size(); ++f) {
        for (std::size_t d = 0; d < ways[f].size(); ++d) {
          if (ways[f][d] == 0) continue;
          for (int p : r.powers) {
            const std::size_t nd = dmax > 0 ? d + static_cast<std::size_t>(p) : 0;
            if (nd > static_cast<std::size_t>(dmax)) break;
            next[f + 1][nd] = add(next[f + 1][nd], ways[f][d]);
          }
        }
      }
      ways = std::move(next);
    }
  }
  std::int64_t total = 0;
  for (std::size_t f = 1; f < ways.size(); ++f) {
    for (const std::int64_t w : ways[f]) total = add(total, w);
  }
  return spec.constant ? add(total, 1) : total;
}

std::vector<SemTerm> GenerateCandidates(const SemSpec& spec) {
  if (const std::int64_t n = CountCandidateCombinations(spec); n > spec.max_candidates) {
    throw InputError(
        spec.path, 0,
        fmt::format("candidate set too large: {}{} factor combinations > limit {} "
                    "(lower max_factors/max_degree, powers or delays, or raise "
                    "[limits] max_candidates / --max-candidates)",
                    n >= (std::int64_t{1} << 62) ? ">= " : "", n, spec.max_candidates));
  }
  struct Slot {
    int regressor;
    int delay;
  };
  std::vector<Slot> slots;
  for (std::size_t r = 0; r < spec.regressors.size(); ++r) {
    for (int d : spec.regressors[r].delays) slots.push_back({static_cast<int>(r), d});
  }
  std::vector<std::vector<SemTerm>> by_count(static_cast<std::size_t>(spec.max_factors) + 1);
  SemTerm cur;
  // Depth-first over slots: each slot absent or at one of its powers.
  auto rec = [&](auto&& self, std::size_t i, int degree) -> void {
    if (i == slots.size()) {
      by_count[cur.factors.size()].push_back(cur);
      return;
    }
    if (static_cast<int>(cur.factors.size()) < spec.max_factors) {
      for (int p : spec.regressors[slots[i].regressor].powers) {
        if (spec.max_degree > 0 && degree + p > spec.max_degree) break;
        cur.factors.push_back({slots[i].regressor, slots[i].delay, p});
        self(self, i + 1, degree + p);
        cur.factors.pop_back();
      }
    }
    self(self, i + 1, degree);
  };
  rec(rec, 0, 0);
  std::vector<SemTerm> out;
  std::set<std::string> seen;
  if (spec.constant) {
    out.push_back(SemTerm{});
  }
  seen.insert(TermKey(spec, SemTerm{}));
  for (std::size_t n = 1; n < by_count.size(); ++n) {
    for (auto& t : by_count[n]) {
      if (seen.insert(TermKey(spec, t)).second) out.push_back(std::move(t));
    }
  }
  if (out.empty()) {
    throw InputError(spec.path, 0, "empty candidate set: the regressors and limits allow no term");
  }
  return out;
}

}  // namespace mrd::host
