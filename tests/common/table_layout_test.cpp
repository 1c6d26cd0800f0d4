// The coefficient table and model validation at their documented limits and byte offsets
// (docs/table_format.md): boundary values accepted and round-tripped, the next value refused,
// non-zero fields written little-endian where the format says, flags refused.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>

#include "mrd/common/crc32.hpp"
#include "mrd/common/model_check.hpp"
#include "mrd/common/table.hpp"
#include "support/demo_model.hpp"

namespace mrd {
namespace {

TableBytes Encoded(const CoefficientTable& t) {
  const auto r = EncodeTable(t);
  EXPECT_TRUE(r.ok()) << ErrorName(r.error());
  return r.ok() ? r.value() : TableBytes{};
}

// Rewrites the CRC after a deliberate change, so the decoder reaches its field checks.
void FixCrc(TableBytes& b) {
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(b.data(), kTableCrcOffset));
  for (std::size_t i = 0; i < 4; ++i) {
    b[kTableCrcOffset + i] = static_cast<std::uint8_t>(crc >> (8 * i));
  }
}

// Little-endian double at a byte offset, read independently of the decoder.
double F64At(const TableBytes& b, std::size_t at) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(b[at + i]) << (8 * i);
  return std::bit_cast<double>(v);
}

// The demo table with its first factor at the documented maxima: power 16, delay 15.
CoefficientTable AtLimits() {
  CoefficientTable t = test::DemoDamperTable();
  t.model.terms[0].factors[0] = {0, static_cast<std::uint8_t>(kMaxDelay), kMaxPower};
  return t;
}

TEST(TableLayoutTest, MaximumPowerAndDelayValidateEncodeAndDecode) {
  ASSERT_EQ(kMaxPower, 16);
  ASSERT_EQ(kMaxDelay, 15U);
  const CoefficientTable t = AtLimits();
  EXPECT_EQ(t.model.Validate(), Error::kOk);
  EXPECT_EQ(t.model.MaxDelay(), 15);
  const TableBytes b = Encoded(t);
  EXPECT_EQ(b[kTableTermsOffset + 5], 15);  // term 0, factor 0: delay
  EXPECT_EQ(b[kTableTermsOffset + 6], 16);  // power
  const auto d = DecodeTable(b);
  ASSERT_TRUE(d.ok()) << ErrorName(d.error());
  EXPECT_EQ(d.value().model.terms[0].factors[0].delay, 15);
  EXPECT_EQ(d.value().model.terms[0].factors[0].power, 16);
}

TEST(TableLayoutTest, OneBeyondMaximumPowerOrDelayIsRefusedEverywhere) {
  CoefficientTable t = AtLimits();
  t.model.terms[0].factors[0].power = kMaxPower + 1;
  EXPECT_EQ(t.model.Validate(), Error::kOutOfRange);
  EXPECT_EQ(EncodeTable(t).error(), Error::kOutOfRange);
  t = AtLimits();
  t.model.terms[0].factors[0].delay = kMaxDelay + 1;
  EXPECT_EQ(t.model.Validate(), Error::kOutOfRange);
  EXPECT_EQ(EncodeTable(t).error(), Error::kOutOfRange);
}

TEST(TableLayoutTest, OutputChannelMustBeBelowTheChannelCount) {
  CoefficientTable t = test::DemoDamperTable();
  t.model.output_channel = t.model.num_channels;  // one past the last channel
  EXPECT_EQ(t.model.Validate(), Error::kOutOfRange);
  EXPECT_EQ(EncodeTable(t).error(), Error::kOutOfRange);
  TableBytes b = Encoded(test::DemoDamperTable());
  b[kTableCountsOffset + 1] = 3;  // output channel 3 of 3
  FixCrc(b);
  EXPECT_EQ(DecodeTable(b).error(), Error::kOutOfRange);
}

TEST(TableLayoutTest, FullCapacityModelValidatesAndRoundTrips) {
  // 8 channels, 16 regressors, 64 terms of 4 factors: every count at its capacity.
  CoefficientTable t = test::DemoDamperTable();
  Model& m = t.model;
  m.num_channels = kMaxChannels;
  for (std::size_t c = 3; c < kMaxChannels; ++c) {
    m.channel_names[c] = {'c', static_cast<char>('0' + c), '\0'};
    m.scales[c] = {0.0, 1.0};
  }
  m.num_regressors = kMaxRegressors;
  for (std::size_t r = 5; r < kMaxRegressors; ++r) {
    m.regressors[r] = {static_cast<std::uint8_t>(3 + r % 5), Transform::kIdentity, 1.0};
  }
  m.num_terms = kMaxTerms;
  for (std::size_t i = 8; i < kMaxTerms; ++i) {
    m.terms[i].num_factors = kMaxFactors;
    for (std::size_t f = 0; f < kMaxFactors; ++f) {
      m.terms[i].factors[f] = {static_cast<std::uint8_t>(1 + (i + f) % 15),
                               static_cast<std::uint8_t>(f), 1};
    }
    m.coefficients[i] = 1e-3 * static_cast<double>(i);
  }
  ASSERT_EQ(m.Validate(), Error::kOk);
  const auto d = DecodeTable(Encoded(t));
  ASSERT_TRUE(d.ok()) << ErrorName(d.error());
  EXPECT_EQ(d.value().model.num_channels, kMaxChannels);
  EXPECT_EQ(d.value().model.num_regressors, kMaxRegressors);
  EXPECT_EQ(d.value().model.num_terms, kMaxTerms);
  EXPECT_EQ(d.value().model.coefficients[kMaxTerms - 1], m.coefficients[kMaxTerms - 1]);
  EXPECT_EQ(d.value().model.terms[kMaxTerms - 1].factors[kMaxFactors - 1].regressor,
            m.terms[kMaxTerms - 1].factors[kMaxFactors - 1].regressor);
}

TEST(TableLayoutTest, EncodesNonZeroFieldsLittleEndianAtDocumentedOffsets) {
  CoefficientTable t = test::DemoDamperTable();
  t.e_min = 0.5;     // 0x3FE0000000000000: byte order shows
  t.e_max = 2.0625;  // 0x4000800000000000
  t.model.scales[2] = {-12.5, 1500.0};
  const TableBytes b = Encoded(t);
  // Counts at 12: channels, output, input, regressors, terms.
  EXPECT_EQ(b[12], 3);
  EXPECT_EQ(b[13], 2);
  EXPECT_EQ(b[14], 1);
  EXPECT_EQ(b[15], 5);
  EXPECT_EQ(b[16], 8);
  // E_min at 20, lowest byte first; E_max at 28.
  for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(b[20 + i], 0) << i;
  EXPECT_EQ(b[26], 0xE0);
  EXPECT_EQ(b[27], 0x3F);
  EXPECT_EQ(b[28 + 5], 0x80);
  EXPECT_EQ(b[28 + 7], 0x40);
  EXPECT_EQ(F64At(b, kTableRangeOffset), 0.5);
  EXPECT_EQ(F64At(b, kTableRangeOffset + 8), 2.0625);
  // Channel 2 record at 36 + 2 * 32: name, offset at +16, scale at +24.
  const std::size_t ch2 = kTableChannelsOffset + 2 * kTableChannelRecord;
  EXPECT_EQ(std::memcmp(&b[ch2], "f\0\0", 3), 0);
  EXPECT_EQ(F64At(b, ch2 + 16), -12.5);
  EXPECT_EQ(F64At(b, ch2 + 24), 1500.0);
  EXPECT_EQ(F64At(b, kTableChannelsOffset + 24), 15.0);  // channel 0 scale
  // Regressor 2 (|v|^0.2): channel, transform, exponent at +8.
  const std::size_t r2 = kTableRegressorsOffset + 2 * kTableRegressorRecord;
  EXPECT_EQ(b[r2], 0);
  EXPECT_EQ(b[r2 + 1], 1);
  EXPECT_EQ(F64At(b, r2 + 8), 0.2);
  // Term 4: three factors (regressor, delay, power) from +4; coefficients from 1572.
  const std::size_t t4 = kTableTermsOffset + 4 * kTableTermRecord;
  EXPECT_EQ(b[t4], 3);
  EXPECT_EQ(b[t4 + 4 + 3 * 2], 3);  // factor 2: sign(v)
  for (std::size_t i = 0; i < t.model.num_terms; ++i) {
    EXPECT_EQ(F64At(b, kTableCoefficientsOffset + 8 * i), t.model.coefficients[i]) << i;
  }
  // CRC-32 of everything before it, little-endian at 2228 (version 3).
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(b.data(), kTableCrcOffset));
  EXPECT_EQ(b[kTableCrcOffset], crc & 0xFFU);
  EXPECT_EQ(b[kTableCrcOffset + 3], crc >> 24);
}

TEST(TableLayoutTest, DecodesNonZeroRangeAndOffsetsFromTheirBytes) {
  CoefficientTable t = test::DemoDamperTable();
  t.e_min = 0.5;
  t.e_max = 2.0625;
  t.model.scales[2] = {-12.5, 1500.0};
  const auto d = DecodeTable(Encoded(t));
  ASSERT_TRUE(d.ok()) << ErrorName(d.error());
  EXPECT_EQ(d.value().e_min, 0.5);
  EXPECT_EQ(d.value().e_max, 2.0625);
  EXPECT_EQ(d.value().model.scales[2].offset, -12.5);
}

// Version 3 defines flag bits 0 (envelope present; tests/common/robust_test.cpp) and 1
// (invertibility record); every other bit is refused.
TEST(TableLayoutTest, DecoderRejectsAnyUndefinedFlagWithValidCrc) {
  for (const auto& [at, value] :
       {std::pair<std::size_t, std::uint8_t>{6, 0x04}, {6, 0x80}, {6, 0x07}, {7, 0x01}}) {
    TableBytes b = Encoded(test::DemoDamperTable());
    b[at] = value;
    FixCrc(b);
    EXPECT_EQ(DecodeTable(b).error(), Error::kOutOfRange) << "byte " << at;
  }
  TableBytes b = Encoded(test::DemoDamperTable());
  EXPECT_EQ(b[6], 0);
  EXPECT_EQ(b[7], 0);
  EXPECT_TRUE(DecodeTable(b).ok());
}

// The diagnosis of an undefined flag says flags, not a stray byte: the firmware's refusal
// is built from it.
TEST(TableLayoutTest, AnUndefinedFlagIsDiagnosedAsAFlagNotAStrayByte) {
  TableBytes b = Encoded(test::DemoDamperTable());
  b[6] = 0x04;
  FixCrc(b);
  TableDiagnosis d;
  EXPECT_EQ(DecodeTable(b, &d).error(), Error::kOutOfRange);
  EXPECT_FALSE(d.stray_byte) << "byte " << d.byte;
}

}  // namespace
}  // namespace mrd
