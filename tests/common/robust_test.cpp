// Issue 13: saturating transforms (tanh, clip) and the coefficient table version 2 with the
// operating envelope (label robust).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "mrd/common/crc32.hpp"
#include "mrd/common/model.hpp"
#include "mrd/common/model_check.hpp"
#include "mrd/common/table.hpp"
#include "support/fev_table.hpp"

namespace mrd {
namespace {

TEST(SaturatingTransformTest, TanhAndClipValues) {
  EXPECT_DOUBLE_EQ(ApplyTransform<double>(Transform::kTanh, 0.5, 0.25), std::tanh(0.5));
  EXPECT_DOUBLE_EQ(ApplyTransform<double>(Transform::kTanh, 0.5, -100.0), -1.0);
  EXPECT_DOUBLE_EQ(ApplyTransform<double>(Transform::kClip, 0.8, 0.3), 0.3);
  EXPECT_DOUBLE_EQ(ApplyTransform<double>(Transform::kClip, 0.8, 5.0), 0.8);
  EXPECT_DOUBLE_EQ(ApplyTransform<double>(Transform::kClip, 0.8, -5.0), -0.8);
  EXPECT_FLOAT_EQ(ApplyTransform<float>(Transform::kClip, 0.8f, -0.8f), -0.8f);
}

// f(k) = 0.5 f(k-1) + 0.3 tanh(v(k)/0.2) + 0.2 clip(v(k-1), 0.5) * E(k), normalised.
CoefficientTable SaturatingTable() {
  CoefficientTable t = test::FevTableSkeleton();
  Model& m = t.model;
  m.num_regressors = 4;
  m.regressors[0] = {0, Transform::kIdentity, 1.0};
  m.regressors[1] = {2, Transform::kTanh, 0.2};
  m.regressors[2] = {2, Transform::kClip, 0.5};
  m.regressors[3] = {1, Transform::kIdentity, 1.0};
  m.num_terms = 3;
  m.terms[0].num_factors = 1;
  m.terms[0].factors[0] = {0, 1, 1};
  m.coefficients[0] = 0.5;
  m.terms[1].num_factors = 1;
  m.terms[1].factors[0] = {1, 0, 1};
  m.coefficients[1] = 0.3;
  m.terms[2].num_factors = 2;
  m.terms[2].factors[0] = {2, 1, 1};
  m.terms[2].factors[1] = {3, 0, 1};
  m.coefficients[2] = 0.2;
  return t;
}

TEST(SaturatingTransformTest, ModelStaysBoundedForAnyVelocity) {
  const CoefficientTable t = SaturatingTable();
  ASSERT_EQ(t.Validate(), Error::kOk);
  ModelRunner runner(t.model);
  double peak = 0.0;
  for (int k = 0; k < 5000; ++k) {
    const double v = 1e6 * std::sin(0.01 * k);  // far beyond any data
    const double row[] = {0.0, 2.25, v};
    peak = std::max(peak, std::fabs(runner.Step(row)));
  }
  // |f| <= 1000 (0.3 + 0.2 * 0.5) / (1 - 0.5) = 800 N for every input.
  EXPECT_LE(peak, 800.0 + 1e-9);
  EXPECT_GT(peak, 700.0);
}

TEST(SaturatingTransformTest, NonPositiveScaleOrLimitIsRefused) {
  for (const Transform tr : {Transform::kTanh, Transform::kClip}) {
    for (const double bad : {0.0, -1.0}) {
      CoefficientTable t = SaturatingTable();
      t.model.regressors[1] = {2, tr, bad};
      const ModelCheck c = CheckTable(t);
      EXPECT_EQ(c.problem, ModelProblem::kSaturation);
      EXPECT_EQ(c.index, 1);
      EXPECT_EQ(t.Validate(), Error::kOutOfRange);
    }
  }
  CoefficientTable t = SaturatingTable();
  t.model.regressors[1].transform = static_cast<Transform>(6);  // after kClip
  EXPECT_EQ(CheckTable(t).problem, ModelProblem::kRegressorTransform);
}

TEST(SaturatingTransformTest, InverterRefusesSaturatedCommand) {
  CoefficientTable t = SaturatingTable();
  t.model.regressors[3] = {1, Transform::kTanh, 1.0};  // tanh(E(k)): not polynomial in E(k)
  const InversionCheck c = CheckInversion(t);
  EXPECT_EQ(c.problem, InversionProblem::kTransform);
  EXPECT_EQ(c.term, 2);
  t.model.regressors[3] = {1, Transform::kClip, 1.0};
  EXPECT_EQ(CheckInversion(t).problem, InversionProblem::kTransform);
  // Saturating transforms of other inputs, or of E at delay >= 1, are fine.
  EXPECT_EQ(CheckInversion(SaturatingTable()).problem, InversionProblem::kNone);
}

CoefficientTable EnvelopeTable() {
  CoefficientTable t = SaturatingTable();
  t.has_envelope = true;
  t.envelope[0] = {-1471.1, 1460.6};
  t.envelope[1] = {0.0, 2.25};
  t.envelope[2] = {-15.0, 15.0};
  return t;
}

TEST(TableV2Test, EnvelopeRoundTrips) {
  const auto bytes = EncodeTable(EnvelopeTable());
  ASSERT_TRUE(bytes.ok());
  const auto& b = bytes.value();
  EXPECT_EQ(b.size(), 2232u);
  EXPECT_EQ(b[4] | (b[5] << 8), 3);  // version
  EXPECT_EQ(b[6] | (b[7] << 8), 1);  // flags: envelope
  const auto d = DecodeTable(b);
  ASSERT_TRUE(d.ok()) << ErrorName(d.error());
  EXPECT_TRUE(d.value().has_envelope);
  EXPECT_EQ(d.value().envelope[0].min, -1471.1);
  EXPECT_EQ(d.value().envelope[2].max, 15.0);
  EXPECT_EQ(d.value().model.regressors[1].transform, Transform::kTanh);
  EXPECT_EQ(d.value().model.regressors[2].transform, Transform::kClip);
  EXPECT_EQ(d.value().model.regressors[2].exponent, 0.5);
  EXPECT_EQ(EncodeTable(d.value()).value(), b);
}

TEST(TableV2Test, WithoutEnvelopeFlagIsZeroAndSectionEmpty) {
  const auto b = EncodeTable(SaturatingTable()).value();
  EXPECT_EQ(b[6] | (b[7] << 8), 0);
  for (std::size_t i = kTableEnvelopeOffset; i < kTableCrcOffset; ++i) EXPECT_EQ(b[i], 0) << i;
  EXPECT_FALSE(DecodeTable(b).value().has_envelope);
}

// A version 1 image of the same table: the v2 image without the envelope section.
std::vector<std::uint8_t> V1Image(const CoefficientTable& t) {
  const auto v2 = EncodeTable(t).value();
  std::vector<std::uint8_t> v1(v2.begin(), v2.begin() + kTableCrcOffsetV1);
  v1[4] = 1;
  v1[5] = 0;
  v1[8] = static_cast<std::uint8_t>(kTableSizeV1 & 0xFF);
  v1[9] = static_cast<std::uint8_t>(kTableSizeV1 >> 8);
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(v1));
  for (int i = 0; i < 4; ++i) v1.push_back(static_cast<std::uint8_t>(crc >> (8 * i)));
  return v1;
}

TEST(TableV2Test, VersionOneImageStillDecodes) {
  const std::vector<std::uint8_t> v1 = V1Image(SaturatingTable());
  ASSERT_EQ(v1.size(), 2088u);
  const auto d = DecodeTable(v1);
  ASSERT_TRUE(d.ok()) << ErrorName(d.error());
  EXPECT_FALSE(d.value().has_envelope);
  EXPECT_EQ(d.value().model.coefficients[2], 0.2);
  // A version 1 image with the envelope flag (undefined in v1) is refused.
  std::vector<std::uint8_t> flagged = V1Image(SaturatingTable());
  flagged[6] = 1;
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(flagged.data(), kTableCrcOffsetV1));
  for (int i = 0; i < 4; ++i)
    flagged[kTableCrcOffsetV1 + i] = static_cast<std::uint8_t>(crc >> (8 * i));
  EXPECT_EQ(DecodeTable(flagged).error(), Error::kOutOfRange);
  // Version 1 size with a version 2 header, and the reverse, are refused.
  std::vector<std::uint8_t> wrong = v1;
  wrong[4] = 2;
  EXPECT_EQ(DecodeTable(wrong).error(), Error::kBadSize);
  auto v2 = EncodeTable(SaturatingTable()).value();
  v2[4] = 1;
  EXPECT_EQ(DecodeTable(v2).error(), Error::kBadSize);
  v2[4] = 4;
  EXPECT_EQ(DecodeTable(v2).error(), Error::kBadVersion);
}

// Re-signs a v2 image after an edit.
void Resign(TableBytes& b) {
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(b.data(), kTableCrcOffset));
  for (int i = 0; i < 4; ++i) b[kTableCrcOffset + i] = static_cast<std::uint8_t>(crc >> (8 * i));
}

TEST(TableV2Test, DecoderRefusesBadEnvelopeAndUnknownFlags) {
  auto b = EncodeTable(EnvelopeTable()).value();
  b[6] = 5;  // bit 2 undefined (bit 1: the invertibility record, version 3)
  Resign(b);
  EXPECT_EQ(DecodeTable(b).error(), Error::kOutOfRange);

  CoefficientTable inverted = EnvelopeTable();
  inverted.envelope[2] = {15.0, -15.0};
  EXPECT_EQ(CheckTable(inverted).problem, ModelProblem::kEnvelopeRange);
  EXPECT_EQ(EncodeTable(inverted).error(), Error::kOutOfRange);
  CoefficientTable nan = EnvelopeTable();
  nan.envelope[0].max = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(CheckTable(nan).problem, ModelProblem::kEnvelopeNonFinite);
  EXPECT_EQ(EncodeTable(nan).error(), Error::kNonFinite);

  // The same problems written into an image are found by the decoder.
  auto e = EncodeTable(EnvelopeTable()).value();
  const std::size_t at = kTableEnvelopeOffset + 2 * kTableEnvelopeRecord;  // v: min, max
  std::swap_ranges(e.begin() + static_cast<std::ptrdiff_t>(at),
                   e.begin() + static_cast<std::ptrdiff_t>(at + 8),
                   e.begin() + static_cast<std::ptrdiff_t>(at + 8));
  Resign(e);
  EXPECT_EQ(DecodeTable(e).error(), Error::kOutOfRange);
  auto n = EncodeTable(EnvelopeTable()).value();
  for (std::size_t i = 0; i < 8; ++i) n[kTableEnvelopeOffset + i] = 0xFF;  // NaN
  Resign(n);
  EXPECT_EQ(DecodeTable(n).error(), Error::kNonFinite);
}

}  // namespace
}  // namespace mrd
