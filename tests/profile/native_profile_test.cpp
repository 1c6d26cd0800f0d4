// The mrd-native profile (firmware/profiles/mrd-native.toml with docs/mrd.dbc) through the
// generic frame codec gives the built-in native codec's frames bit for bit, for every message,
// and reads them back as that codec does; the compiled-in copy equals the file.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>

#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::profile {
namespace {

namespace pc = protocol::can;
const std::string kSource = MRD_SOURCE_DIR;

SignalRef In(const CanProfile& p, CanIn r) { return p.inputs[static_cast<std::size_t>(r)]; }
SignalRef Out(const CanProfile& p, CanOut r) { return p.outputs[static_cast<std::size_t>(r)]; }
int MessageOf(const CanProfile& p, const char* name) {
  for (std::size_t m = 0; m < p.dbc.messages.size(); ++m) {
    if (p.dbc.messages[m].name == name) return static_cast<int>(m);
  }
  return -1;
}
bool Same(const can_frame& a, const can_frame& b) {
  return a.can_id == b.can_id && a.len == b.len && std::memcmp(a.data, b.data, 8) == 0;
}

TEST(NativeProfileTest, TheCompiledInProfileEqualsTheFile) {
  CanProfile file;
  std::string error;
  ASSERT_TRUE(LoadCanProfile(kSource + "/firmware/profiles/mrd-native.toml", &file, &error))
      << error;
  const CanProfile& built = NativeCanProfile();
  EXPECT_EQ(built.name, "mrd-native");
  ASSERT_EQ(built.dbc.messages.size(), file.dbc.messages.size());
  for (std::size_t r = 0; r < kNumCanIn; ++r) {
    EXPECT_EQ(built.inputs[r].message, file.inputs[r].message);
    EXPECT_EQ(built.inputs[r].signal, file.inputs[r].signal);
  }
  for (std::size_t r = 0; r < kNumCanOut; ++r) {
    EXPECT_EQ(built.outputs[r].message, file.outputs[r].message);
    EXPECT_EQ(built.outputs[r].signal, file.outputs[r].signal);
  }
  for (std::size_t m = 0; m < built.specs.size(); ++m) {
    EXPECT_EQ(built.specs[m].counter, file.specs[m].counter);
    EXPECT_EQ(built.specs[m].checksum, file.specs[m].checksum);
  }
}

TEST(NativeProfileTest, EveryMessageIsTheNativeCodecsFrameBitForBit) {
  const CanProfile& p = NativeCanProfile();
  FrameCodec tx(p), rx(p);
  std::mt19937 rng(20261125);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int motion = MessageOf(p, "SensorMotion"), force = MessageOf(p, "SensorForce"),
            grant = MessageOf(p, "TimeGrant"), command = MessageOf(p, "DriverCommand"),
            heartbeat = MessageOf(p, "Heartbeat"), dstatus = MessageOf(p, "DriverStatus"),
            fstatus = MessageOf(p, "FirmwareStatus");
  for (int k = 0; k < 500; ++k) {
    const auto c4 = static_cast<std::uint8_t>(k & 15);
    can_frame want{}, got{};
    // SensorMotion
    const pc::SensorMotion sm{299.0 * u(rng), 29.0 * u(rng), static_cast<std::uint16_t>(k * 977),
                              c4};
    ASSERT_EQ(pc::Encode(sm, &want), pc::Reject::kNone);
    tx.Begin(motion, &got);
    ASSERT_EQ(tx.Set(&got, In(p, CanIn::kVelocity), sm.velocity), protocol::SignalError::kNone);
    ASSERT_EQ(tx.Set(&got, In(p, CanIn::kDisplacement), sm.displacement),
              protocol::SignalError::kNone);
    ASSERT_EQ(tx.Set(&got, In(p, CanIn::kSensorSeq), sm.seq), protocol::SignalError::kNone);
    tx.Seal(motion, &got);
    EXPECT_TRUE(Same(want, got)) << "SensorMotion " << k;
    ASSERT_EQ(rx.Find(want), motion);
    EXPECT_EQ(rx.Check(motion, want), pc::Reject::kNone);
    pc::SensorMotion back;
    ASSERT_EQ(pc::Decode(want, &back), pc::Reject::kNone);
    double v = 0;
    ASSERT_EQ(rx.Get(want, In(p, CanIn::kVelocity), &v), protocol::SignalError::kNone);
    EXPECT_DOUBLE_EQ(v, back.velocity);
    // SensorForce
    const pc::SensorForce sf{14000.0 * u(rng), 299.0 * u(rng), 14000.0 * u(rng), c4};
    ASSERT_EQ(pc::Encode(sf, &want), pc::Reject::kNone);
    tx.Begin(force, &got);
    (void)tx.Set(&got, In(p, CanIn::kDemand), sf.demand);
    (void)tx.Set(&got, In(p, CanIn::kBodyVelocity), sf.body_velocity);
    (void)tx.Set(&got, In(p, CanIn::kForce), sf.force);
    tx.Seal(force, &got);
    EXPECT_TRUE(Same(want, got)) << "SensorForce " << k;
    // TimeGrant
    const pc::TimeGrant tg{static_cast<std::uint64_t>(k) * 1000U + 17U, c4};
    ASSERT_EQ(pc::Encode(tg, &want), pc::Reject::kNone);
    tx.Begin(grant, &got);
    (void)tx.Set(&got, In(p, CanIn::kGrant), static_cast<double>(tg.time_us));
    tx.Seal(grant, &got);
    EXPECT_TRUE(Same(want, got)) << "TimeGrant " << k;
    // DriverCommand
    const pc::DriverCommand dc{12.0 + 11.9 * u(rng),
                               (k & 1) != 0,
                               (k & 2) != 0,
                               (k & 4) != 0,
                               static_cast<std::uint16_t>(k * 31),
                               c4};
    ASSERT_EQ(pc::Encode(dc, &want), pc::Reject::kNone);
    tx.Begin(command, &got);
    (void)tx.Set(&got, Out(p, CanOut::kCommand), dc.volts);
    (void)tx.Set(&got, Out(p, CanOut::kEnable), dc.enable ? 1.0 : 0.0);
    (void)tx.Set(&got, Out(p, CanOut::kEnableValid), dc.enable_valid ? 1.0 : 0.0);
    (void)tx.Set(&got, Out(p, CanOut::kSafe), dc.safe ? 1.0 : 0.0);
    (void)tx.Set(&got, Out(p, CanOut::kEcho), dc.echo_seq);
    tx.Seal(command, &got);
    EXPECT_TRUE(Same(want, got)) << "DriverCommand " << k;
    // Heartbeat
    const pc::Heartbeat hb{(k & 1) != 0, c4};
    ASSERT_EQ(pc::Encode(hb, &want), pc::Reject::kNone);
    tx.Begin(heartbeat, &got);
    (void)tx.Set(&got, Out(p, CanOut::kHeartbeatSafe), hb.safe ? 1.0 : 0.0);
    tx.Seal(heartbeat, &got);
    EXPECT_TRUE(Same(want, got)) << "Heartbeat " << k;
    // DriverStatus
    const pc::DriverStatus ds{5.0 + 4.9 * u(rng), static_cast<std::uint8_t>(k & 31), c4};
    ASSERT_EQ(pc::Encode(ds, &want), pc::Reject::kNone);
    tx.Begin(dstatus, &got);
    (void)tx.Set(&got, In(p, CanIn::kDriverCurrent), ds.current);
    (void)tx.Set(&got, In(p, CanIn::kDriverFaults), ds.faults);
    tx.Seal(dstatus, &got);
    EXPECT_TRUE(Same(want, got)) << "DriverStatus " << k;
    // FirmwareStatus: 8-bit sequence, no checksum
    const pc::FirmwareStatus fs{(k & 1) != 0, static_cast<std::uint16_t>(k * 7),
                                static_cast<std::uint16_t>(k), static_cast<std::uint16_t>(k / 3),
                                static_cast<std::uint8_t>(k & 255)};
    ASSERT_EQ(pc::Encode(fs, &want), pc::Reject::kNone);
    tx.Begin(fstatus, &got);
    (void)tx.Set(&got, Out(p, CanOut::kStatusSafe), fs.safe ? 1.0 : 0.0);
    (void)tx.Set(&got, Out(p, CanOut::kStatusCauses), fs.active_causes);
    (void)tx.Set(&got, Out(p, CanOut::kStatusOverruns), fs.overruns);
    (void)tx.Set(&got, Out(p, CanOut::kStatusSafeEntries), fs.safe_entries);
    tx.Seal(fstatus, &got);
    EXPECT_TRUE(Same(want, got)) << "FirmwareStatus " << k;
  }
}

TEST(NativeProfileTest, ReceiverChecksAreTheNativeOnes) {
  const CanProfile& p = NativeCanProfile();
  FrameCodec rx(p);
  const int motion = MessageOf(p, "SensorMotion");
  can_frame f{};
  ASSERT_EQ(pc::Encode(pc::SensorMotion{1.0, 0.5, 7, 3}, &f), pc::Reject::kNone);
  EXPECT_EQ(rx.Check(motion, f), pc::Reject::kNone);
  EXPECT_EQ(rx.Check(motion, f), pc::Reject::kRepeatedCounter);
  ASSERT_EQ(pc::Encode(pc::SensorMotion{1.0, 0.5, 8, 12}, &f), pc::Reject::kNone);  // 9 ahead
  EXPECT_EQ(rx.Check(motion, f), pc::Reject::kStaleCounter);
  ASSERT_EQ(pc::Encode(pc::SensorMotion{1.0, 0.5, 9, 13}, &f), pc::Reject::kNone);  // resynced
  EXPECT_EQ(rx.Check(motion, f), pc::Reject::kNone);
  f.data[2] ^= 0x10;
  EXPECT_EQ(rx.Check(motion, f), pc::Reject::kBadChecksum);
  f.len = 7;
  EXPECT_EQ(rx.Check(motion, f), pc::Reject::kWrongDlc);
  can_frame other{};
  other.can_id = 0x123;
  EXPECT_EQ(rx.Find(other), -1);
  other.can_id = 0x100 | CAN_EFF_FLAG;  // extended 0x100 is not the standard SensorMotion
  EXPECT_EQ(rx.Find(other), -1);
}

}  // namespace
}  // namespace mrd::profile
