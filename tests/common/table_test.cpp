#include "mrd/common/table.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string_view>

#include "mrd/common/crc32.hpp"
#include "support/demo_model.hpp"

namespace mrd {
namespace {

TableBytes Encoded(const CoefficientTable& t) {
  const auto r = EncodeTable(t);
  EXPECT_TRUE(r.ok()) << ErrorName(r.error());
  return r.value();
}

// Rewrites the CRC after a deliberate corruption, so the decoder reaches its field checks.
void FixCrc(TableBytes& b) {
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(b.data(), kTableCrcOffset));
  for (std::size_t i = 0; i < 4; ++i)
    b[kTableCrcOffset + i] = static_cast<std::uint8_t>(crc >> (8 * i));
}

void PutF64(TableBytes& b, std::size_t at, double d) {
  const auto v = std::bit_cast<std::uint64_t>(d);
  for (std::size_t i = 0; i < 8; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

Error DecodeError(const TableBytes& b) { return DecodeTable(b).error(); }

TEST(Crc32Test, MatchesStandardCheckValue) {
  constexpr std::string_view kCheck = "123456789";
  const auto* p = reinterpret_cast<const std::uint8_t*>(kCheck.data());
  EXPECT_EQ(Crc32({p, kCheck.size()}), 0xCBF43926U);
  EXPECT_EQ(Crc32(std::span<const std::uint8_t>{}), 0U);
  // Running CRC over two pieces equals the CRC of the whole.
  EXPECT_EQ(Crc32({p + 4, 5}, Crc32({p, 4})), 0xCBF43926U);
}

TEST(TableTest, RoundTripPreservesEveryField) {
  const CoefficientTable t = test::DemoDamperTable();
  const TableBytes bytes = Encoded(t);
  const auto decoded = DecodeTable(bytes);
  ASSERT_TRUE(decoded.ok()) << ErrorName(decoded.error());
  const CoefficientTable& d = decoded.value();
  EXPECT_EQ(d.input_channel, 1);
  EXPECT_EQ(d.e_min, 0.0);
  EXPECT_EQ(d.e_max, 2.25);
  ASSERT_EQ(d.model.num_terms, t.model.num_terms);
  for (std::size_t i = 0; i < t.model.num_terms; ++i) {
    EXPECT_EQ(d.model.coefficients[i], t.model.coefficients[i]);
    ASSERT_EQ(d.model.terms[i].num_factors, t.model.terms[i].num_factors);
    for (std::size_t f = 0; f < t.model.terms[i].num_factors; ++f) {
      EXPECT_EQ(d.model.terms[i].factors[f].regressor, t.model.terms[i].factors[f].regressor);
      EXPECT_EQ(d.model.terms[i].factors[f].delay, t.model.terms[i].factors[f].delay);
      EXPECT_EQ(d.model.terms[i].factors[f].power, t.model.terms[i].factors[f].power);
    }
  }
  for (std::size_t r = 0; r < t.model.num_regressors; ++r) {
    EXPECT_EQ(d.model.regressors[r].channel, t.model.regressors[r].channel);
    EXPECT_EQ(d.model.regressors[r].transform, t.model.regressors[r].transform);
    EXPECT_EQ(d.model.regressors[r].exponent, t.model.regressors[r].exponent);
  }
  for (std::size_t c = 0; c < t.model.num_channels; ++c) {
    EXPECT_STREQ(d.model.channel_names[c].data(), t.model.channel_names[c].data());
    EXPECT_EQ(d.model.scales[c].offset, t.model.scales[c].offset);
    EXPECT_EQ(d.model.scales[c].scale, t.model.scales[c].scale);
  }
  EXPECT_EQ(Encoded(d), bytes);  // re-encoding gives the same image
}

TEST(TableTest, LowPassRegressorRoundTripsAndBadTauIsRejected) {
  CoefficientTable t = test::DemoDamperTable();
  const std::size_t r = t.model.num_regressors++;
  t.model.regressors[r] = {1, Transform::kLowPass, 6.5};  // low-pass of E, tau 6.5 samples
  const auto d = DecodeTable(Encoded(t));
  ASSERT_TRUE(d.ok()) << ErrorName(d.error());
  EXPECT_EQ(d.value().model.regressors[r].transform, Transform::kLowPass);
  EXPECT_EQ(d.value().model.regressors[r].exponent, 6.5);
  TableBytes b = Encoded(t);
  PutF64(b, kTableRegressorsOffset + kTableRegressorRecord * r + 8, -1.0);  // tau <= 0
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
}

TEST(TableTest, ImageIsLittleEndianWithMagicVersionAndSize) {
  const TableBytes b = Encoded(test::DemoDamperTable());
  EXPECT_EQ(std::memcmp(b.data(), "MRDT", 4), 0);
  EXPECT_EQ(b[4], 3);  // version 3, low byte first
  EXPECT_EQ(b[5], 0);
  EXPECT_EQ(b[8] | (b[9] << 8) | (b[10] << 16) | (b[11] << 24), static_cast<int>(kTableSize));
  // e_max = 2.25 = 0x4002000000000000 little-endian at offset 28.
  EXPECT_EQ(b[kTableRangeOffset + 8 + 7], 0x40);
  EXPECT_EQ(b[kTableRangeOffset + 8 + 6], 0x02);
}

TEST(TableTest, DecoderRejectsWrongMagic) {
  TableBytes b = Encoded(test::DemoDamperTable());
  b[0] = 'X';
  EXPECT_EQ(DecodeError(b), Error::kBadMagic);
}

TEST(TableTest, DecoderRejectsWrongVersion) {
  TableBytes b = Encoded(test::DemoDamperTable());
  b[4] = 4;  // versions 1, 2 and 3 are known (tests/common/robust_test.cpp)
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kBadVersion);
  b[4] = 0;
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kBadVersion);
  // The version is 16 bits: a high byte makes 0x0102, not version 2.
  b[4] = 2;
  b[5] = 1;
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kBadVersion);
}

TEST(TableTest, DecoderRejectsWrongSize) {
  const TableBytes b = Encoded(test::DemoDamperTable());
  EXPECT_EQ(DecodeTable(std::span(b).first(kTableSize - 1)).error(), Error::kBadSize);
  EXPECT_EQ(DecodeTable(std::span(b).first(5)).error(), Error::kBadSize);
  std::array<std::uint8_t, kTableSize + 1> longer{};
  std::copy(b.begin(), b.end(), longer.begin());
  EXPECT_EQ(DecodeTable(longer).error(), Error::kBadSize);
  TableBytes wrong_field = b;
  wrong_field[8] = 0;
  EXPECT_EQ(DecodeError(wrong_field), Error::kBadSize);
}

TEST(TableTest, DecoderRejectsCrcMismatch) {
  TableBytes b = Encoded(test::DemoDamperTable());
  b[kTableCoefficientsOffset + 3] ^= 0x10;  // one flipped bit in a coefficient
  EXPECT_EQ(DecodeError(b), Error::kBadCrc);
  TableBytes c = Encoded(test::DemoDamperTable());
  c[kTableCrcOffset] ^= 0x01;
  EXPECT_EQ(DecodeError(c), Error::kBadCrc);
}

TEST(TableTest, DecoderRejectsOutOfRangeIndices) {
  TableBytes b = Encoded(test::DemoDamperTable());
  b[kTableTermsOffset + 4] = 9;  // term 0, factor 0: regressor 9 of 5
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
  b = Encoded(test::DemoDamperTable());
  b[kTableRegressorsOffset] = 7;  // regressor 0 reads channel 7 of 3
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
  b = Encoded(test::DemoDamperTable());
  b[kTableCountsOffset + 2] = 2;  // input channel == output channel
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
  b = Encoded(test::DemoDamperTable());
  b[kTableRegressorsOffset + 1] = 6;  // unknown transform (5, clip, is the last)
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
  b = Encoded(test::DemoDamperTable());
  ASSERT_EQ(test::DemoDamperTable().model.regressors[0].channel, 2);  // the output f
  b[kTableRegressorsOffset + 1] = 3;  // low-pass on the output channel
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
  b = Encoded(test::DemoDamperTable());
  b[kTableTermsOffset + 5] = kMaxDelay + 1;  // delay
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
}

TEST(TableTest, DecoderRejectsOutOfRangePowers) {
  TableBytes b = Encoded(test::DemoDamperTable());
  b[kTableTermsOffset + 6] = 0;
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
  b[kTableTermsOffset + 6] = kMaxPower + 1;
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
}

TEST(TableTest, DecoderRejectsCountsOverCapacity) {
  TableBytes b = Encoded(test::DemoDamperTable());
  b[kTableCountsOffset + 4] = kTableTerms + 1;
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kCapacityExceeded);
  b = Encoded(test::DemoDamperTable());
  b[kTableTermsOffset] = kTableFactors + 1;
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kCapacityExceeded);
}

TEST(TableTest, DecoderRejectsNonFiniteValues) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  TableBytes b = Encoded(test::DemoDamperTable());
  PutF64(b, kTableCoefficientsOffset + 8 * 3, nan);
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kNonFinite);
  b = Encoded(test::DemoDamperTable());
  PutF64(b, kTableCoefficientsOffset, inf);
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kNonFinite);
  b = Encoded(test::DemoDamperTable());
  PutF64(b, kTableChannelsOffset + 24, inf);  // scale of channel 0
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kNonFinite);
  b = Encoded(test::DemoDamperTable());
  PutF64(b, kTableRangeOffset + 8, nan);  // e_max
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kNonFinite);
}

TEST(TableTest, DecoderRejectsEmptyVoltageRange) {
  TableBytes b = Encoded(test::DemoDamperTable());
  PutF64(b, kTableRangeOffset + 8, 0.0);  // e_max == e_min
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kOutOfRange);
}

TEST(TableTest, DecoderRejectsUnterminatedName) {
  TableBytes b = Encoded(test::DemoDamperTable());
  for (std::size_t i = 0; i < 16; ++i) b[kTableChannelsOffset + i] = 'a';
  FixCrc(b);
  EXPECT_EQ(DecodeError(b), Error::kInvalidArgument);
}

TEST(TableTest, EncoderRefusesModelOverCapacity) {
  CoefficientTable t = test::DemoDamperTable();
  t.model.num_terms = kTableTerms + 1;
  EXPECT_EQ(EncodeTable(t).error(), Error::kCapacityExceeded);
  t = test::DemoDamperTable();
  t.model.terms[0].num_factors = kTableFactors + 1;
  EXPECT_EQ(EncodeTable(t).error(), Error::kCapacityExceeded);
  t = test::DemoDamperTable();
  t.model.num_regressors = kTableRegressors + 1;
  EXPECT_EQ(EncodeTable(t).error(), Error::kCapacityExceeded);
}

TEST(TableTest, EncoderRefusesInvalidInputChannelAndRange) {
  CoefficientTable t = test::DemoDamperTable();
  t.input_channel = 2;  // the output
  EXPECT_EQ(EncodeTable(t).error(), Error::kOutOfRange);
  t = test::DemoDamperTable();
  t.e_min = 3.0;
  EXPECT_EQ(EncodeTable(t).error(), Error::kOutOfRange);
}

}  // namespace
}  // namespace mrd
