#include "mrd/firmware/platform/table_file.hpp"

#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "mrd/common/input_file.hpp"

namespace mrd::firmware::platform {
namespace {

// Reads and decodes; *why (when given) gets the decoder's diagnosis, *file the open's.
Result<CoefficientTable> Load(const char* path, TableDiagnosis* why, InputFile* file, int* err) {
  // A longer file is refused by its size before anything is read.
  const InputFile f = OpenInputFile(path, kTableSize);
  if (file != nullptr) *file = f;
  if (f.fd < 0) return f.too_large ? Error::kBadSize : Error::kIo;
  std::array<std::uint8_t, kTableSize + 1> buf{};  // one more byte detects a file that grew
  std::size_t n = 0;
  while (n < buf.size()) {
    const ssize_t r = ::read(f.fd, buf.data() + n, buf.size() - n);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      if (err != nullptr) *err = errno;
      ::close(f.fd);
      return Error::kIo;
    }
    if (r == 0) break;
    n += static_cast<std::size_t>(r);
  }
  ::close(f.fd);
  const std::span<const std::uint8_t> image(buf.data(), n);
  return why != nullptr ? DecodeTable(image, why) : DecodeTable(image);
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  // The shortest of %g's 6 digits and the exact form that reads back the same value.
  char shortest[32];
  std::snprintf(shortest, sizeof shortest, "%g", v);
  return std::strtod(shortest, nullptr) == v ? shortest : buf;
}

std::string Sizes() {
  return "a table image is " + std::to_string(kTableSize) + " bytes (version 3), " +
         std::to_string(kTableSizeV2) + " (version 2) or " + std::to_string(kTableSizeV1) +
         " (version 1)";
}

// The field a byte offset falls in (canonical zero bytes: reserved fields and unused slots).
std::string Field(std::size_t at, const CoefficientTable& t) {
  const Model& m = t.model;
  auto slot = [](const char* what, std::size_t i, std::size_t used, const char* count) {
    return std::string(what) + " " + std::to_string(i) +
           (i >= used ? " (unused: the table has " + std::to_string(used) + " " + count + ")"
                      : std::string());
  };
  if (at < kTableRangeOffset) return "header, reserved";
  if (at < kTableChannelsOffset) return "voltage range";
  if (at < kTableRegressorsOffset) {
    const std::size_t c = (at - kTableChannelsOffset) / kTableChannelRecord;
    const std::size_t in = (at - kTableChannelsOffset) % kTableChannelRecord;
    return slot("channel", c, m.num_channels, "channels") +
           (in <= kMaxNameLength && c < m.num_channels ? ", name after its NUL" : "");
  }
  if (at < kTableTermsOffset) {
    const std::size_t r = (at - kTableRegressorsOffset) / kTableRegressorRecord;
    return slot("regressor", r, m.num_regressors, "regressors") +
           (r < m.num_regressors ? ", reserved" : "");
  }
  if (at < kTableCoefficientsOffset) {
    const std::size_t i = (at - kTableTermsOffset) / kTableTermRecord;
    return slot("term", i, m.num_terms, "terms") +
           (i < m.num_terms ? ", reserved or unused factor" : "");
  }
  if (at < kTableEnvelopeOffset) {
    return slot("coefficient", (at - kTableCoefficientsOffset) / 8, m.num_terms, "terms");
  }
  if (at >= kTableInvertibilityOffset) {
    return "invertibility record (flag bit 1 clear: no record)";
  }
  const std::size_t c = (at - kTableEnvelopeOffset) / kTableEnvelopeRecord;
  return t.has_envelope ? slot("envelope of channel", c, m.num_channels, "channels")
                        : "envelope (flag bit 0 clear: no envelope)";
}

std::string Name(const CoefficientTable& t, std::size_t c) {
  std::string s = "'";  // appended, not "'" + ...: GCC 12's false -Wrestrict (bug 105329)
  s += Printable(t.model.channel_names[c].data());
  s += '\'';
  return s;
}

std::string Content(const TableDiagnosis& d) {
  const CoefficientTable& t = d.table;
  const Model& m = t.model;
  const std::size_t i = d.check.index;
  switch (d.check.problem) {
    case ModelProblem::kNone:
      return "";
    case ModelProblem::kNoChannels:
      return "no channels";
    case ModelProblem::kTooManyChannels:
    case ModelProblem::kTooManyRegressors:
    case ModelProblem::kTooManyTerms:
    case ModelProblem::kTooManyFactors:
      return "a count over the format's capacity";
    case ModelProblem::kOutputChannel:
      return "output channel index out of range";
    case ModelProblem::kChannelName:
      return "channel " + std::to_string(i) +
             " name is empty, has no NUL in its 16 bytes or is not printable ASCII";
    case ModelProblem::kChannelScaleNonFinite:
    case ModelProblem::kChannelScale:
      return "channel " + Name(t, i) + " normalisation offset " + Num(m.scales[i].offset) +
             ", scale " + Num(m.scales[i].scale) + " (needs |offset| <= " + Num(kMaxChannelOffset) +
             ", scale in [" + Num(kMinChannelScale) + ", " + Num(kMaxChannelScale) + "])";
    case ModelProblem::kChannelNameRepeated:
      return "channels " + std::to_string(d.check.count) + " and " + std::to_string(i) +
             " are both named " + Name(t, i);
    case ModelProblem::kRegressorChannel:
      return "regressor " + std::to_string(i) + " reads no channel";
    case ModelProblem::kRegressorTransform:
      return "regressor " + std::to_string(i) + " has an unknown transform";
    case ModelProblem::kRegressorExponent:
    case ModelProblem::kAbsPowExponent:
    case ModelProblem::kLowPass:
    case ModelProblem::kSaturation:
      return "regressor " + std::to_string(i) + " has an invalid exponent " +
             Num(m.regressors[i].exponent) + " for its transform";
    case ModelProblem::kFactorRegressor:
      return "term " + std::to_string(i) + " uses no regressor";
    case ModelProblem::kFactorDelay:
      return "term " + std::to_string(i) + " uses delay " + std::to_string(d.check.count) + " > " +
             std::to_string(kMaxDelay);
    case ModelProblem::kFactorPower:
      return "term " + std::to_string(i) + " uses power " + std::to_string(d.check.count) +
             " (1 ... " + std::to_string(kMaxPower) + ")";
    case ModelProblem::kOutputAtDelayZero:
      return "term " + std::to_string(i) + " uses the output at delay 0";
    case ModelProblem::kCoefficient:
      return "coefficient " + std::to_string(i) + " is not finite";
    case ModelProblem::kInputChannel:
      return "input channel missing or the output";
    case ModelProblem::kVoltageNonFinite:
    case ModelProblem::kVoltageRange:
      return "input range [" + Num(t.e_min) + ", " + Num(t.e_max) + "] V (needs 0 <= E_min < " +
             "E_max <= " + Num(kMaxCommandVoltage) + " V, the set-point range of the buses)";
    case ModelProblem::kEnvelopeNonFinite:
    case ModelProblem::kEnvelopeRange:
      return "envelope of channel " + Name(t, i) + " [" + Num(t.envelope[i].min) + ", " +
             Num(t.envelope[i].max) + "] is empty or not finite";
    case ModelProblem::kInvertibilityNonFinite:
    case ModelProblem::kInvertibilityCount:
      return "invertibility record: " + std::to_string(t.invertibility.failing) + " failing of " +
             std::to_string(t.invertibility.states) + " states, worst slope " +
             Num(t.invertibility.worst_slope) + " (needs failing <= states, a finite slope)";
  }
  return "";
}

}  // namespace

Result<CoefficientTable> LoadTableFile(const char* path) {
  return Load(path, nullptr, nullptr, nullptr);
}

Result<CoefficientTable> LoadTableFile(const char* path, std::string* reason) {
  TableDiagnosis why;
  InputFile file;
  int err = 0;
  Result<CoefficientTable> r = Load(path, &why, &file, &err);
  if (r.ok()) return r;
  if (file.fd < 0 && file.too_large) {
    *reason = "is " + std::to_string(file.size) + " bytes; " + Sizes();
  } else if (file.fd < 0) {
    *reason = InputFileRefusal(file, kTableSize);
  } else if (r.error() == Error::kIo) {
    *reason = std::strerror(err);
  } else {
    *reason = DescribeTableRefusal(why);
  }
  return r;
}

std::string DescribeTableRefusal(const TableDiagnosis& d) {
  std::string what = ErrorName(d.error);
  if (d.error == Error::kBadSize) {
    return what + ": " + std::to_string(d.size) + " bytes or a size field that disagrees; " +
           Sizes();
  }
  if (d.stray_byte) {
    char value[8];
    std::snprintf(value, sizeof value, "0x%02x", d.byte_value);
    return what + ": byte " + std::to_string(d.byte) + " (" + Field(d.byte, d.table) + ") is " +
           value + ", must be 0";
  }
  if (!d.check.ok()) return what + ": " + Content(d);
  if (d.error == Error::kOutOfRange) {
    return what + ": a flag the version does not define is set (version 3: bits 0 and 1; " +
           "version 2: bit 0; version 1: none)";
  }
  return what;
}

}  // namespace mrd::firmware::platform
