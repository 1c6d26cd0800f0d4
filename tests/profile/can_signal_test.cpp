// The DBC signal codec (mrd::protocol, can_signal.hpp): Intel and Motorola bit layouts, sign,
// factor and offset, ranges; checked on known answers and against the frame codec of
// docs/mrd.dbc (can_codec.hpp).
#include "mrd/protocol/can_signal.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "mrd/protocol/can_codec.hpp"

namespace mrd::protocol {
namespace {

SignalLayout Layout(int start, int length, ByteOrder order, bool is_signed, double factor = 1.0,
                    double offset = 0.0, double min = 0.0, double max = 0.0) {
  SignalLayout s;
  s.start_bit = static_cast<std::uint16_t>(start);
  s.length = static_cast<std::uint8_t>(length);
  s.order = order;
  s.is_signed = is_signed;
  s.factor = factor;
  s.offset = offset;
  s.min = min;
  s.max = max;
  return s;
}

TEST(CanSignalTest, IntelFieldsAreLittleEndianFromTheStartBit) {
  const std::uint8_t d[8] = {0x34, 0x12, 0xF0, 0, 0, 0, 0, 0};
  EXPECT_EQ(ExtractRaw(d, Layout(0, 16, ByteOrder::kIntel, false)), 0x1234);
  EXPECT_EQ(ExtractRaw(d, Layout(4, 8, ByteOrder::kIntel, false)), 0x23);  // crosses a byte
  EXPECT_EQ(ExtractRaw(d, Layout(20, 4, ByteOrder::kIntel, false)), 0xF);
  EXPECT_EQ(ExtractRaw(d, Layout(20, 4, ByteOrder::kIntel, true)), -1);  // sign-extended
}

TEST(CanSignalTest, MotorolaFieldsFollowTheSawtoothFromTheirMsb) {
  // Start bit 7 (MSB of byte 0), 16 bits: bytes 0..1 big-endian.
  const std::uint8_t d[8] = {0x12, 0x34, 0xAB, 0xCD, 0, 0, 0, 0};
  EXPECT_EQ(ExtractRaw(d, Layout(7, 16, ByteOrder::kMotorola, false)), 0x1234);
  // Start bit 3, 8 bits: low nibble of byte 0 then high nibble of byte 1.
  EXPECT_EQ(ExtractRaw(d, Layout(3, 8, ByteOrder::kMotorola, false)), 0x23);
  // Start bit 23, 12 bits: byte 2 then the high nibble of byte 3.
  EXPECT_EQ(ExtractRaw(d, Layout(23, 12, ByteOrder::kMotorola, false)), 0xABC);
  std::uint64_t mask = 0;
  ASSERT_TRUE(SignalMask(Layout(23, 12, ByteOrder::kMotorola, false), &mask));
  EXPECT_EQ(mask, 0xF0FF0000ULL);
}

TEST(CanSignalTest, InsertThenExtractRoundTripsEveryLayoutAndLeavesOtherBits) {
  for (const ByteOrder order : {ByteOrder::kIntel, ByteOrder::kMotorola}) {
    for (int length = 1; length <= 64; length += 7) {
      for (int start = 0; start < 64; start += 5) {
        const SignalLayout s = Layout(start, length, order, true);
        std::uint64_t mask = 0;
        if (!SignalMask(s, &mask)) continue;
        std::uint8_t d[8];
        for (std::uint8_t& b : d) b = 0xA5;
        const std::int64_t raw = length == 64 ? -123456789 : -(std::int64_t{1} << (length - 1)) / 3;
        InsertRaw(d, s, raw);
        EXPECT_EQ(ExtractRaw(d, s), raw) << start << " " << length;
        for (int b = 0; b < 64; ++b) {
          if ((mask >> b) & 1U) continue;
          EXPECT_EQ((d[b / 8] >> (b % 8)) & 1, (0xA5 >> (b % 8)) & 1) << "bit " << b;
        }
      }
    }
  }
}

TEST(CanSignalTest, PhysicalValuesUseFactorOffsetAndRange) {
  const SignalLayout s = Layout(0, 12, ByteOrder::kIntel, false, 0.5, -100.0, -100.0, 1000.0);
  std::uint8_t d[8] = {};
  ASSERT_EQ(EncodeSignal(d, s, 12.3), SignalError::kNone);  // raw round((12.3+100)/0.5) = 225
  EXPECT_EQ(ExtractRaw(d, s), 225);
  double v = 0;
  EXPECT_EQ(DecodeSignal(d, s, &v), SignalError::kNone);
  EXPECT_DOUBLE_EQ(v, 12.5);
  EXPECT_EQ(EncodeSignal(d, s, 1000.5), SignalError::kOutOfRange);
  EXPECT_EQ(EncodeSignal(d, s, std::nan("")), SignalError::kNotFinite);
  EXPECT_EQ(ExtractRaw(d, s), 225);  // refused values write nothing
  InsertRaw(d, s, 4095);             // 1947.5: outside [min, max]
  EXPECT_EQ(DecodeSignal(d, s, &v), SignalError::kOutOfRange);
  // No DBC limits ([0|0]): only the field's raw range bounds an encode.
  const SignalLayout open = Layout(0, 8, ByteOrder::kIntel, true);
  EXPECT_EQ(EncodeSignal(d, open, 127.0), SignalError::kNone);
  EXPECT_EQ(EncodeSignal(d, open, 128.0), SignalError::kOutOfRange);
  EXPECT_EQ(EncodeSignal(d, open, -128.0), SignalError::kNone);
}

TEST(CanSignalTest, FitsOnlyWithinTheMessageLength) {
  EXPECT_TRUE(SignalFits(Layout(0, 16, ByteOrder::kIntel, false), 2));
  EXPECT_FALSE(SignalFits(Layout(8, 16, ByteOrder::kIntel, false), 2));
  EXPECT_TRUE(SignalFits(Layout(7, 16, ByteOrder::kMotorola, false), 2));
  EXPECT_FALSE(SignalFits(Layout(7, 24, ByteOrder::kMotorola, false), 2));
  EXPECT_FALSE(SignalFits(Layout(60, 8, ByteOrder::kIntel, false), 8));  // past bit 63
  EXPECT_FALSE(SignalFits(Layout(0, 0, ByteOrder::kIntel, false), 8));
}

// The generic codec reads the frames of the project's own codec as docs/mrd.dbc describes them.
TEST(CanSignalTest, AgreesWithTheFrameCodecOfTheNativeDbc) {
  can_frame f{};
  ASSERT_EQ(can::Encode(can::SensorMotion{-12.34, 1.234, 4321, 5}, &f), can::Reject::kNone);
  double v = 0;
  EXPECT_EQ(DecodeSignal(f.data, Layout(0, 16, ByteOrder::kIntel, true, 0.01, 0, -300, 300), &v),
            SignalError::kNone);
  EXPECT_DOUBLE_EQ(v, -12.34);
  EXPECT_EQ(DecodeSignal(f.data, Layout(16, 16, ByteOrder::kIntel, true, 0.001, 0, -30, 30), &v),
            SignalError::kNone);
  EXPECT_DOUBLE_EQ(v, 1.234);
  EXPECT_EQ(ExtractRaw(f.data, Layout(32, 16, ByteOrder::kIntel, false)), 4321);
  EXPECT_EQ(ExtractRaw(f.data, Layout(48, 4, ByteOrder::kIntel, false)), 5);
}

}  // namespace
}  // namespace mrd::protocol
