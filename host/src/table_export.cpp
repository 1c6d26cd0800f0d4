#include "mrd/host/table_export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "mrd/common/crc32.hpp"
#include "mrd/common/model_check.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host {
namespace {

std::string Fits(const char* what, std::size_t have, std::size_t limit) {
  if (have <= limit) return "";
  return fmt::format("model has {} {}; table format v{} holds at most {}", have, what,
                     kTableVersion, limit);
}

bool IsIdentifier(std::string_view s) {
  if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0])) != 0) return false;
  for (const char c : s) {
    if (std::isalnum(static_cast<unsigned char>(c)) == 0 && c != '_') return false;
  }
  return true;
}

std::string Num(double d) { return fmt::format("{}", d); }

std::string CharLiteral(char c) {
  if (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-' || c == '.') {
    return fmt::format("'{}'", c);
  }
  return fmt::format("'\\x{:02x}'", static_cast<unsigned char>(c));
}

const char* TransformName(Transform t) {
  switch (t) {
    case Transform::kIdentity:
      return "mrd::Transform::kIdentity";
    case Transform::kAbsPow:
      return "mrd::Transform::kAbsPow";
    case Transform::kSign:
      return "mrd::Transform::kSign";
    case Transform::kLowPass:
      return "mrd::Transform::kLowPass";
    case Transform::kTanh:
      return "mrd::Transform::kTanh";
    case Transform::kClip:
      return "mrd::Transform::kClip";
  }
  return "mrd::Transform::kIdentity";
}

}  // namespace

std::string TableFitProblem(const ModelShape& s) {
  for (std::string p :
       {s.channels == 0 ? std::string("model has no channels") : std::string(),
        Fits("channels", s.channels, kTableChannels),
        Fits("elementary regressors", s.regressors, kTableRegressors),
        Fits("terms", s.terms, kTableTerms),
        Fits("factors in one term", s.max_factors, kTableFactors),
        s.max_delay > kMaxDelay ? fmt::format("model uses delay {}; table format v{} holds at "
                                              "most {}",
                                              s.max_delay, kTableVersion, kMaxDelay)
                                : std::string(),
        s.max_power > kMaxPower ? fmt::format("model uses power {}; table format v{} holds at "
                                              "most {}",
                                              s.max_power, kTableVersion, +kMaxPower)
                                : std::string()}) {
    if (!p.empty()) return p;
  }
  return "";
}

namespace {

// Words for common's reason codes (CheckTable); the checking itself lives in common/.
std::string FormatModelCheck(const CoefficientTable& table, const ModelCheck& c) {
  const Model& m = table.model;
  const std::size_t i = c.index;
  const auto count = static_cast<std::size_t>(c.count);
  switch (c.problem) {
    case ModelProblem::kNone:
      return "";
    case ModelProblem::kNoChannels:
      return "model has no channels";
    case ModelProblem::kTooManyChannels:
      return Fits("channels", count, kTableChannels);
    case ModelProblem::kTooManyRegressors:
      return Fits("elementary regressors", count, kTableRegressors);
    case ModelProblem::kTooManyTerms:
      return Fits("terms", count, kTableTerms);
    case ModelProblem::kTooManyFactors:
      return Fits("factors in one term", count, kTableFactors);
    case ModelProblem::kOutputChannel:
      return "output channel index out of range";
    case ModelProblem::kChannelName:
      return fmt::format(
          "channel {} name is empty, longer than {} characters or not printable "
          "ASCII",
          i, kMaxNameLength);
    case ModelProblem::kChannelScaleNonFinite:
    case ModelProblem::kChannelScale:
      return fmt::format("channel '{}' has an invalid normalisation (offset {}, scale {})",
                         m.channel_names[i].data(), m.scales[i].offset, m.scales[i].scale);
    case ModelProblem::kChannelNameRepeated:
      return fmt::format("channels {} and {} are both named '{}'", c.count, i,
                         m.channel_names[i].data());
    case ModelProblem::kRegressorChannel:
      return fmt::format("regressor {} reads no channel", i);
    case ModelProblem::kRegressorTransform:
      return fmt::format("regressor {} has an unknown transform", i);
    case ModelProblem::kRegressorExponent:
    case ModelProblem::kAbsPowExponent:
      return fmt::format("regressor {} has an invalid exponent {}", i, m.regressors[i].exponent);
    case ModelProblem::kLowPass:
      return fmt::format(
          "regressor {} is a low-pass with tau {} samples on {} (input channels, "
          "0 < tau <= {:g})",
          i, m.regressors[i].exponent,
          m.regressors[i].channel == m.output_channel ? "the output" : "an input", kMaxLowPassTau);
    case ModelProblem::kSaturation:
      return fmt::format("regressor {} is a tanh or clip with scale/limit {} (must be > 0)", i,
                         m.regressors[i].exponent);
    case ModelProblem::kFactorRegressor:
      return fmt::format("term {} uses no regressor", i);
    case ModelProblem::kFactorDelay:
      return fmt::format("term {} uses delay {} > {}", i, c.count, kMaxDelay);
    case ModelProblem::kFactorPower:
      return fmt::format("term {} uses power {} (1 ... {})", i, c.count, +kMaxPower);
    case ModelProblem::kOutputAtDelayZero:
      return fmt::format("term {} uses the output at delay 0", i);
    case ModelProblem::kCoefficient:
      return fmt::format("coefficient {} is not finite", i);
    case ModelProblem::kInputChannel:
      return "input channel is missing or is the output";
    case ModelProblem::kVoltageNonFinite:
    case ModelProblem::kVoltageRange:
      return fmt::format("voltage range [{}, {}] is empty, not finite or outside [0, {}] V",
                         table.e_min, table.e_max, kMaxCommandVoltage);
    case ModelProblem::kEnvelopeNonFinite:
    case ModelProblem::kEnvelopeRange:
      return fmt::format("envelope of channel '{}' [{}, {}] is empty or not finite",
                         m.channel_names[i].data(), table.envelope[i].min, table.envelope[i].max);
    case ModelProblem::kInvertibilityNonFinite:
    case ModelProblem::kInvertibilityCount:
      return fmt::format(
          "invertibility record: {} failing of {} states, worst slope {} (failing <= states, "
          "finite slope)",
          table.invertibility.failing, table.invertibility.states, table.invertibility.worst_slope);
  }
  return ErrorName(c.error());
}

}  // namespace

std::string DescribeTableProblem(const CoefficientTable& table) {
  const Model& m = table.model;
  if (const ModelCheck c = CheckTable(table); !c.ok()) return FormatModelCheck(table, c);
  const InversionCheck inv = CheckInversion(table);
  const char* input = m.channel_names[table.input_channel].data();
  switch (inv.problem) {
    case InversionProblem::kNone:
      return "";
    case InversionProblem::kTransform:
      return fmt::format(
          "not invertible in '{}': term {} takes {}(k) through abs_pow, sign, "
          "tanh or clip (the firmware needs a polynomial in {}(k))",
          input, inv.term, input, input);
    case InversionProblem::kDegree:
      return fmt::format("not invertible in '{}': term {} has degree {} in {}(k) > {}", input,
                         inv.term, inv.degree, input, kMaxInputDegree);
    case InversionProblem::kAbsent:
      return fmt::format("not invertible in '{}': {}(k) does not enter the model at delay 0", input,
                         input);
  }
  return "";
}

CoefficientTable MakeUncheckedTable(const Model& model, double e_min, double e_max,
                                    std::string_view input_channel, const std::string& source) {
  CoefficientTable t;
  t.model = model;
  t.e_min = e_min;
  t.e_max = e_max;
  const int c = model.num_channels <= kMaxChannels
                    ? model.ChannelIndex(std::string(input_channel).c_str())
                    : -1;
  if (c < 0) {
    throw InputError(source, 0, fmt::format("model has no input channel '{}'", input_channel));
  }
  t.input_channel = static_cast<std::uint8_t>(c);
  return t;
}

CoefficientTable MakeTable(const Model& model, double e_min, double e_max,
                           std::string_view input_channel, const std::string& source) {
  CoefficientTable t = MakeUncheckedTable(model, e_min, e_max, input_channel, source);
  if (std::string p = DescribeTableProblem(t); !p.empty()) throw InputError(source, 0, p);
  return t;
}

TableBytes TableImage(const CoefficientTable& table) {
  const auto r = EncodeTable(table);
  if (!r.ok()) {
    std::string p = DescribeTableProblem(table);
    throw InputError("", 0, p.empty() ? ErrorName(r.error()) : p);
  }
  return r.value();
}

namespace {

// C++20 keywords, alternative tokens and the preprocessor's own names: not usable as a name.
// clang-format off
constexpr std::array<std::string_view, 95> kKeywords = {
    "alignas", "alignof", "and", "and_eq", "asm", "auto", "bitand", "bitor", "bool", "break",
    "case", "catch", "char", "char8_t", "char16_t", "char32_t", "class", "compl", "concept",
    "const", "consteval", "constexpr", "constinit", "const_cast", "continue", "co_await",
    "co_return", "co_yield", "decltype", "default", "delete", "do", "double", "dynamic_cast",
    "else", "enum", "explicit", "export", "extern", "false", "float", "for", "friend", "goto", "if",
    "inline", "int", "long", "mutable", "namespace", "new", "noexcept", "not", "not_eq", "nullptr",
    "operator", "or", "or_eq", "private", "protected", "public", "register", "reinterpret_cast",
    "requires", "return", "short", "signed", "sizeof", "static", "static_assert", "static_cast",
    "struct", "switch", "template", "this", "thread_local", "throw", "true", "try", "typedef",
    "typeid", "typename", "union", "unsigned", "using", "virtual", "void", "volatile", "wchar_t",
    "while", "xor", "xor_eq", "_Pragma", "__VA_ARGS__", "__VA_OPT__"};
// clang-format on

bool IsKeyword(std::string_view s) {
  return std::find(kKeywords.begin(), kKeywords.end(), s) != kKeywords.end();
}

// The names of a (qualified) C++ identifier "ns::...::name"; std::invalid_argument otherwise
// (a part that is not an identifier, or a keyword such as "namespace").
std::vector<std::string_view> SymbolParts(std::string_view symbol) {
  std::vector<std::string_view> parts;
  for (std::size_t at = 0;;) {
    const std::size_t sep = symbol.find("::", at);
    parts.push_back(symbol.substr(at, sep == std::string_view::npos ? sep : sep - at));
    if (sep == std::string_view::npos) break;
    at = sep + 2;
  }
  for (const std::string_view p : parts) {
    if (!IsIdentifier(p)) {
      throw std::invalid_argument(fmt::format("'{}' is not a C++ identifier", symbol));
    }
    if (IsKeyword(p)) {
      throw std::invalid_argument(
          fmt::format("'{}': '{}' is a C++ keyword, not usable as a name", symbol, p));
    }
  }
  return parts;
}

}  // namespace

std::string TableHeader(const CoefficientTable& table, std::string_view symbol) {
  SymbolParts(symbol);  // the symbol first, then the encoding
  return TableHeader(table, symbol, TableImage(table));
}

std::string TableHeader(const CoefficientTable& table, std::string_view symbol,
                        const TableBytes& image) {
  const std::vector<std::string_view> parts = SymbolParts(symbol);
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(image.data(), kTableCrcOffset));
  const Model& m = table.model;
  std::string s;
  auto line = [&s](const std::string& text) { s += text + "\n"; };
  line("#pragma once");
  line("// Generated by mrd::host::TableHeader (mrd export) -- do not edit.");
  line(
      fmt::format("// Coefficient table format v{}: {} channels, {} regressors, {} terms; input "
                  "'{}' in [{}, {}] V.",
                  kTableVersion, m.num_channels, m.num_regressors, m.num_terms,
                  m.channel_names[table.input_channel].data(), Num(table.e_min), Num(table.e_max)));
  line(fmt::format("// Binary image: {} bytes, CRC-32 0x{:08X}.", kTableSize, crc));
  line("");
  line("#include \"mrd/common/table.hpp\"");
  line("");
  const std::string_view name = parts.back();
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) line(fmt::format("namespace {} {{", parts[i]));
  if (parts.size() > 1) line("");
  line(fmt::format("inline constexpr mrd::CoefficientTable {} = [] {{", name));
  line("  mrd::CoefficientTable t{};");
  line(fmt::format("  t.input_channel = {};", table.input_channel));
  line(fmt::format("  t.e_min = {};", Num(table.e_min)));
  line(fmt::format("  t.e_max = {};", Num(table.e_max)));
  if (table.has_envelope) {
    line("  t.has_envelope = true;");
    for (std::size_t c = 0; c < table.model.num_channels; ++c) {
      line(fmt::format("  t.envelope[{}] = {{{}, {}}};", c, Num(table.envelope[c].min),
                       Num(table.envelope[c].max)));
    }
  }
  if (table.has_invertibility) {
    line("  t.has_invertibility = true;");
    line(fmt::format("  t.invertibility = {{{}, {}, {}}};", table.invertibility.states,
                     table.invertibility.failing, Num(table.invertibility.worst_slope)));
  }
  line("  mrd::Model& m = t.model;");
  line(fmt::format("  m.num_channels = {};", m.num_channels));
  line(fmt::format("  m.output_channel = {};", m.output_channel));
  for (std::size_t c = 0; c < m.num_channels; ++c) {
    std::string chars;
    for (const char* p = m.channel_names[c].data(); *p != '\0'; ++p) {
      chars += (chars.empty() ? "" : ", ") + CharLiteral(*p);
    }
    line(fmt::format("  m.channel_names[{}] = {{{}}};", c, chars));
    line(fmt::format("  m.scales[{}] = {{{}, {}}};", c, Num(m.scales[c].offset),
                     Num(m.scales[c].scale)));
  }
  line(fmt::format("  m.num_regressors = {};", m.num_regressors));
  for (std::size_t r = 0; r < m.num_regressors; ++r) {
    line(fmt::format("  m.regressors[{}] = {{{}, {}, {}}};", r, m.regressors[r].channel,
                     TransformName(m.regressors[r].transform), Num(m.regressors[r].exponent)));
  }
  line(fmt::format("  m.num_terms = {};", m.num_terms));
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    const Term& term = m.terms[i];
    line(fmt::format("  m.terms[{}].num_factors = {};", i, term.num_factors));
    for (std::size_t f = 0; f < term.num_factors; ++f) {
      line(fmt::format("  m.terms[{}].factors[{}] = {{{}, {}, {}}};", i, f,
                       term.factors[f].regressor, term.factors[f].delay, term.factors[f].power));
    }
    line(fmt::format("  m.coefficients[{}] = {};", i, Num(m.coefficients[i])));
  }
  line("  return t;");
  line("}();");
  if (parts.size() > 1) line("");
  for (std::size_t i = parts.size() - 1; i-- > 0;)
    line(fmt::format("}}  // namespace {}", parts[i]));
  return s;
}

}  // namespace mrd::host
