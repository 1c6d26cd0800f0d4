#include "mrd/common/table.hpp"

#include <bit>
#include <cmath>

#include "mrd/common/crc32.hpp"
#include "mrd/common/model_check.hpp"

namespace mrd {
namespace {

static_assert(kTableSize == 2232, "format version 3 layout changed: bump kTableVersion");
static_assert(kTableSizeV2 == 2216, "format version 2 layout is fixed");
static_assert(kTableSizeV1 == 2088, "format version 1 layout is fixed");

// Little-endian byte writer over a fixed image.
class Writer {
 public:
  explicit Writer(TableBytes& bytes) : bytes_(bytes) {}
  void U8(std::size_t at, std::uint8_t v) { bytes_[at] = v; }
  void U16(std::size_t at, std::uint16_t v) {
    for (std::size_t i = 0; i < 2; ++i) bytes_[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }
  void U32(std::size_t at, std::uint32_t v) {
    for (std::size_t i = 0; i < 4; ++i) bytes_[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }
  void F64(std::size_t at, double d) {
    const auto v = std::bit_cast<std::uint64_t>(d);
    for (std::size_t i = 0; i < 8; ++i) bytes_[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }

 private:
  TableBytes& bytes_;
};

// Little-endian byte reader; callers have checked the span size.
class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}
  std::uint8_t U8(std::size_t at) const { return bytes_[at]; }
  std::uint16_t U16(std::size_t at) const {
    return static_cast<std::uint16_t>(bytes_[at] | (bytes_[at + 1] << 8));
  }
  std::uint32_t U32(std::size_t at) const {
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(bytes_[at + i]) << (8 * i);
    return v;
  }
  double F64(std::size_t at) const {
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(bytes_[at + i]) << (8 * i);
    return std::bit_cast<double>(v);
  }

 private:
  std::span<const std::uint8_t> bytes_;
};

}  // namespace

Error CoefficientTable::Validate() const { return CheckTable(*this).error(); }

InversionCheck CheckInversion(const CoefficientTable& table) {
  const Model& m = table.model;
  InversionCheck out;
  for (std::size_t i = 0; i < m.num_terms; ++i) {
    int d = 0;
    for (std::size_t f = 0; f < m.terms[i].num_factors; ++f) {
      const Factor& fac = m.terms[i].factors[f];
      if (!IsDirectInput(table, fac)) continue;
      const Transform tr = m.regressors[fac.regressor].transform;
      if (tr != Transform::kIdentity && tr != Transform::kLowPass) {
        return {InversionProblem::kTransform, static_cast<std::uint8_t>(i), 0};
      }
      d += fac.power;
    }
    if (d > kMaxInputDegree) return {InversionProblem::kDegree, static_cast<std::uint8_t>(i), d};
    out.degree = d > out.degree ? d : out.degree;
  }
  if (out.degree == 0) out.problem = InversionProblem::kAbsent;
  return out;
}

Result<TableBytes> EncodeTable(const CoefficientTable& table) {
  const Error e = table.Validate();
  if (e != Error::kOk) return e;
  const Model& m = table.model;
  TableBytes bytes{};
  Writer w(bytes);
  for (std::size_t i = 0; i < kTableMagic.size(); ++i) w.U8(i, kTableMagic[i]);
  w.U16(4, kTableVersion);
  w.U16(6, static_cast<std::uint16_t>((table.has_envelope ? kTableFlagEnvelope : 0) |
                                      (table.has_invertibility ? kTableFlagInvertibility : 0)));
  w.U32(8, static_cast<std::uint32_t>(kTableSize));
  w.U8(kTableCountsOffset + 0, m.num_channels);
  w.U8(kTableCountsOffset + 1, m.output_channel);
  w.U8(kTableCountsOffset + 2, table.input_channel);
  w.U8(kTableCountsOffset + 3, m.num_regressors);
  w.U8(kTableCountsOffset + 4, m.num_terms);
  w.F64(kTableRangeOffset, table.e_min);
  w.F64(kTableRangeOffset + 8, table.e_max);
  for (std::size_t c = 0; c < m.num_channels; ++c) {
    const std::size_t at = kTableChannelsOffset + c * kTableChannelRecord;
    // Bytes after the terminating NUL are written as zeros (canonical image).
    bool ended = false;
    for (std::size_t i = 0; i <= kMaxNameLength; ++i) {
      ended = ended || m.channel_names[c][i] == '\0';
      w.U8(at + i, ended ? 0 : static_cast<std::uint8_t>(m.channel_names[c][i]));
    }
    w.F64(at + 16, m.scales[c].offset);
    w.F64(at + 24, m.scales[c].scale);
  }
  for (std::size_t r = 0; r < m.num_regressors; ++r) {
    const std::size_t at = kTableRegressorsOffset + r * kTableRegressorRecord;
    w.U8(at, m.regressors[r].channel);
    w.U8(at + 1, static_cast<std::uint8_t>(m.regressors[r].transform));
    w.F64(at + 8, m.regressors[r].exponent);
  }
  for (std::size_t t = 0; t < m.num_terms; ++t) {
    const std::size_t at = kTableTermsOffset + t * kTableTermRecord;
    const Term& term = m.terms[t];
    w.U8(at, term.num_factors);
    for (std::size_t f = 0; f < term.num_factors; ++f) {
      w.U8(at + 4 + 3 * f, term.factors[f].regressor);
      w.U8(at + 5 + 3 * f, term.factors[f].delay);
      w.U8(at + 6 + 3 * f, term.factors[f].power);
    }
    w.F64(kTableCoefficientsOffset + 8 * t, m.coefficients[t]);
  }
  if (table.has_envelope) {
    for (std::size_t c = 0; c < m.num_channels; ++c) {
      w.F64(kTableEnvelopeOffset + c * kTableEnvelopeRecord, table.envelope[c].min);
      w.F64(kTableEnvelopeOffset + c * kTableEnvelopeRecord + 8, table.envelope[c].max);
    }
  }
  if (table.has_invertibility) {
    w.U32(kTableInvertibilityOffset, table.invertibility.states);
    w.U32(kTableInvertibilityOffset + 4, table.invertibility.failing);
    w.F64(kTableInvertibilityOffset + 8, table.invertibility.worst_slope);
  }
  w.U32(kTableCrcOffset, Crc32(std::span<const std::uint8_t>(bytes.data(), kTableCrcOffset)));
  return bytes;
}

Result<CoefficientTable> DecodeTable(std::span<const std::uint8_t> bytes) {
  return DecodeTable(bytes, nullptr);
}

Result<CoefficientTable> DecodeTable(std::span<const std::uint8_t> bytes, TableDiagnosis* why) {
  TableDiagnosis scratch;
  TableDiagnosis& d = why != nullptr ? *why : scratch;
  d = TableDiagnosis{};
  d.size = bytes.size();
  const auto refuse = [&d](Error e) {
    d.error = e;
    return e;
  };
  if (bytes.size() < kTableHeaderSize) return refuse(Error::kBadSize);
  const Reader r(bytes);
  for (std::size_t i = 0; i < kTableMagic.size(); ++i) {
    if (r.U8(i) != kTableMagic[i]) return refuse(Error::kBadMagic);
  }
  const std::uint16_t version = r.U16(4);
  if (version != kTableVersion && version != kTableVersionV2 && version != kTableVersionV1) {
    return refuse(Error::kBadVersion);
  }
  const bool v1 = version == kTableVersionV1;
  const bool v2 = version == kTableVersionV2;
  const std::size_t size = v1 ? kTableSizeV1 : (v2 ? kTableSizeV2 : kTableSize);
  const std::size_t crc_at = v1 ? kTableCrcOffsetV1 : (v2 ? kTableCrcOffsetV2 : kTableCrcOffset);
  if (r.U32(8) != size || bytes.size() != size) return refuse(Error::kBadSize);
  if (r.U32(crc_at) != Crc32(bytes.first(crc_at))) return refuse(Error::kBadCrc);
  const std::uint16_t flags = r.U16(6);
  // Version 1 defines no flag; version 2 the envelope bit; version 3 also the invertibility bit.
  const unsigned defined =
      v1 ? 0u
         : (v2 ? unsigned{kTableFlagEnvelope}
               : unsigned{kTableFlagEnvelope} | unsigned{kTableFlagInvertibility});
  if ((flags & ~defined) != 0) return refuse(Error::kOutOfRange);

  CoefficientTable table;
  Model& m = table.model;
  m.num_channels = r.U8(kTableCountsOffset + 0);
  m.output_channel = r.U8(kTableCountsOffset + 1);
  table.input_channel = r.U8(kTableCountsOffset + 2);
  m.num_regressors = r.U8(kTableCountsOffset + 3);
  m.num_terms = r.U8(kTableCountsOffset + 4);
  if (m.num_channels == 0 || m.num_channels > kTableChannels ||
      m.num_regressors > kTableRegressors || m.num_terms > kTableTerms) {
    return refuse(Error::kCapacityExceeded);
  }
  table.e_min = r.F64(kTableRangeOffset);
  table.e_max = r.F64(kTableRangeOffset + 8);
  for (std::size_t c = 0; c < m.num_channels; ++c) {
    const std::size_t at = kTableChannelsOffset + c * kTableChannelRecord;
    for (std::size_t i = 0; i <= kMaxNameLength; ++i) {
      m.channel_names[c][i] = static_cast<char>(r.U8(at + i));
    }
    m.scales[c].offset = r.F64(at + 16);
    m.scales[c].scale = r.F64(at + 24);
  }
  for (std::size_t g = 0; g < m.num_regressors; ++g) {
    const std::size_t at = kTableRegressorsOffset + g * kTableRegressorRecord;
    m.regressors[g].channel = r.U8(at);
    m.regressors[g].transform = static_cast<Transform>(r.U8(at + 1));
    m.regressors[g].exponent = r.F64(at + 8);
  }
  for (std::size_t t = 0; t < m.num_terms; ++t) {
    const std::size_t at = kTableTermsOffset + t * kTableTermRecord;
    Term& term = m.terms[t];
    term.num_factors = r.U8(at);
    if (term.num_factors > kTableFactors) return refuse(Error::kCapacityExceeded);
    for (std::size_t f = 0; f < term.num_factors; ++f) {
      term.factors[f].regressor = r.U8(at + 4 + 3 * f);
      term.factors[f].delay = r.U8(at + 5 + 3 * f);
      term.factors[f].power = r.U8(at + 6 + 3 * f);
    }
    m.coefficients[t] = r.F64(kTableCoefficientsOffset + 8 * t);
  }
  table.has_envelope = (flags & kTableFlagEnvelope) != 0;
  if (table.has_envelope) {
    for (std::size_t c = 0; c < m.num_channels; ++c) {
      table.envelope[c].min = r.F64(kTableEnvelopeOffset + c * kTableEnvelopeRecord);
      table.envelope[c].max = r.F64(kTableEnvelopeOffset + c * kTableEnvelopeRecord + 8);
    }
  }
  table.has_invertibility = (flags & kTableFlagInvertibility) != 0;
  if (table.has_invertibility) {
    table.invertibility.states = r.U32(kTableInvertibilityOffset);
    table.invertibility.failing = r.U32(kTableInvertibilityOffset + 4);
    table.invertibility.worst_slope = r.F64(kTableInvertibilityOffset + 8);
  }
  d.table = table;
  d.check = CheckTable(table);
  if (!d.check.ok()) return refuse(d.check.error());
  // Canonical: every byte the encoder writes as zero is zero (all but the version and size
  // fields, which differ in a version 1 or 2 image, and the CRC, which is checked above).
  const Result<TableBytes> canonical = EncodeTable(table);
  if (!canonical.ok()) return refuse(canonical.error());
  for (std::size_t i = 0; i < crc_at; ++i) {
    if ((i >= 4 && i < 6) || (i >= 8 && i < 12)) continue;
    if (bytes[i] != canonical.value()[i]) {
      d.stray_byte = true;
      d.byte = i;
      d.byte_value = bytes[i];
      return refuse(Error::kOutOfRange);
    }
  }
  return table;
}

}  // namespace mrd
