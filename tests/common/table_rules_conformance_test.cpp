// Conformance (labels conformance, firmware): the decoder refuses images that pass the CRC but
// break docs/table_format.md: a normalisation that makes every period's force non-finite,
// bytes the encoder writes as zero that are not (reserved fields, unused slots), two channels
// of one name, an input range outside the set-point range of the buses [0, 24] V. Images are
// patched byte by byte from the demo table's (tests/support/demo_model.hpp: 8 terms, 5
// regressors, no envelope; the offsets below are its layout) and resealed (CRC), as a tool or
// a corrupted store would make them.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "mrd/common/crc32.hpp"
#include "mrd/common/table.hpp"
#include "support/demo_model.hpp"

namespace mrd {
namespace {

TableBytes Builtin() {
  const auto image = EncodeTable(test::DemoDamperTable());
  EXPECT_TRUE(image.ok());
  return image.value();
}

void PutF64(TableBytes& b, std::size_t at, double v) {
  const auto u = std::bit_cast<std::uint64_t>(v);
  for (std::size_t i = 0; i < 8; ++i) b[at + i] = static_cast<std::uint8_t>(u >> (8 * i));
}

// Recomputes the CRC, so only the patched content can be refused.
Error Decode(TableBytes b) {
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(b.data(), kTableCrcOffset));
  for (std::size_t i = 0; i < 4; ++i)
    b[kTableCrcOffset + i] = static_cast<std::uint8_t>(crc >> (8 * i));
  return DecodeTable(std::span<const std::uint8_t>(b.data(), b.size())).error();
}

std::size_t Channel(std::size_t c) { return kTableChannelsOffset + c * kTableChannelRecord; }

TEST(TableRulesConformance, TheCompiledInImageDecodes) { EXPECT_EQ(Decode(Builtin()), Error::kOk); }

TEST(TableRulesConformance, NormalisationThatOverflowsEveryPeriodIsRefused) {
  for (const double offset : {1e308, -1e308, 1.1e6}) {
    TableBytes b = Builtin();
    PutF64(b, Channel(0) + 16, offset);
    EXPECT_EQ(Decode(b), Error::kOutOfRange) << "offset " << offset;
  }
  for (const double scale : {5e-324, 1e-300, 1e-7, 1e7, 1e300}) {
    TableBytes b = Builtin();
    PutF64(b, Channel(1) + 24, scale);
    EXPECT_EQ(Decode(b), Error::kOutOfRange) << "scale " << scale;
  }
  TableBytes ok = Builtin();
  PutF64(ok, Channel(0) + 16, -1e6);  // the bounds themselves are accepted
  PutF64(ok, Channel(1) + 24, 1e-6);
  PutF64(ok, Channel(2) + 24, 1e6);
  EXPECT_EQ(Decode(ok), Error::kOk);
}

TEST(TableRulesConformance, NonZeroReservedOrUnusedBytesAreRefused) {
  const std::size_t term0 = kTableTermsOffset;      // 1 factor: bytes 1-3 reserved, 7-15 unused
  const std::size_t reg0 = kTableRegressorsOffset;  // bytes 2-7 reserved
  const std::size_t cases[] = {
      17,
      18,
      19,  // header reserved
      Channel(0) + 2,
      Channel(0) + 15,  // name bytes after "v\0"
      Channel(3),
      Channel(7) + 31,  // channel slots beyond the 3 used
      reg0 + 2,
      reg0 + 7,
      kTableRegressorsOffset + 5 * kTableRegressorRecord,  // unused regressor
      term0 + 1,
      term0 + 3,
      term0 + 7,
      term0 + 15,                                // term reserved / unused factors
      kTableTermsOffset + 8 * kTableTermRecord,  // term slot beyond the 8 used
      kTableCoefficientsOffset + 8 * 8 + 7,      // coefficient slot 8 (unused)
      kTableEnvelopeOffset,
      kTableCrcOffset - 1,  // envelope without flag bit 0
  };
  for (const std::size_t at : cases) {
    TableBytes b = Builtin();
    b[at] = 0x01;
    EXPECT_EQ(Decode(b), Error::kOutOfRange) << "byte " << at;
  }
  TableBytes nan_slot = Builtin();  // NaN in an unused coefficient slot
  PutF64(nan_slot, kTableCoefficientsOffset + 8 * 20, std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(Decode(nan_slot), Error::kOutOfRange);
}

TEST(TableRulesConformance, TwoChannelsOfOneNameAreRefused) {
  TableBytes b = Builtin();
  b[Channel(1)] = 'v';  // "E" -> "v": channels 0 and 1 both 'v'
  EXPECT_EQ(Decode(b), Error::kInvalidArgument);
}

TEST(TableRulesConformance, EmptyOrNonAsciiChannelNamesAreRefused) {
  for (const int first : {0x00, 0x01, 0x7f, 0xc3}) {
    TableBytes b = Builtin();
    b[Channel(0)] = static_cast<std::uint8_t>(first);
    EXPECT_EQ(Decode(b), Error::kInvalidArgument) << first;
  }
}

TEST(TableRulesConformance, InputRangeOutsideTheBusesSetPointRangeIsRefused) {
  const struct {
    double e_min, e_max;
  } bad[] = {{-5.0, 2.25}, {0.0, 1000.0}, {-1e-9, 2.25}, {0.0, 24.000001}};
  for (const auto& r : bad) {
    TableBytes b = Builtin();
    PutF64(b, kTableRangeOffset, r.e_min);
    PutF64(b, kTableRangeOffset + 8, r.e_max);
    EXPECT_EQ(Decode(b), Error::kOutOfRange) << "[" << r.e_min << ", " << r.e_max << "]";
  }
  TableBytes full = Builtin();  // [0, 24] V itself is accepted
  PutF64(full, kTableRangeOffset + 8, 24.0);
  EXPECT_EQ(Decode(full), Error::kOk);
}

TEST(TableRulesConformance, EncoderRefusesWhatTheDecoderRefuses) {
  CoefficientTable t = test::DemoDamperTable();
  t.e_max = 1000.0;
  EXPECT_EQ(EncodeTable(t).error(), Error::kOutOfRange);
  t = test::DemoDamperTable();
  t.model.scales[0].offset = 1e308;
  EXPECT_EQ(EncodeTable(t).error(), Error::kOutOfRange);
  t = test::DemoDamperTable();
  std::strcpy(t.model.channel_names[2].data(), "E");
  EXPECT_EQ(EncodeTable(t).error(), Error::kInvalidArgument);
}

}  // namespace
}  // namespace mrd
