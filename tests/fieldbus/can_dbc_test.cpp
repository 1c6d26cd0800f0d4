// docs/mrd.dbc and the codec agree: this test reads the DBC (its own small parser, independent
// of the codec), builds each frame with the codec and extracts every signal by the DBC's start
// bit, length, byte order, sign, scale and offset. IDs, lengths, ranges, counters and
// checksums must match, and every signal of the DBC must be accounted for.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include "mrd/protocol/can_codec.hpp"

namespace mrd::protocol::can {
namespace {

struct DbcSignal {
  int start = 0, length = 0;
  bool little_endian = true, is_signed = false;
  double scale = 1.0, offset = 0.0, min = 0.0, max = 0.0;
};
struct DbcMessage {
  unsigned id = 0;
  int dlc = 0;
  std::map<std::string, DbcSignal> signals;
};

std::map<std::string, DbcMessage> LoadDbc(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  const std::regex bo(R"(^BO_ (\d+) (\w+): (\d+) \w+\s*$)");
  const std::regex sg(
      R"(^ SG_ (\w+) : (\d+)\|(\d+)@([01])([+-]) \(([-\d.eE]+),([-\d.eE]+)\) \[([-\d.eE]+)\|([-\d.eE]+)\] "[^"]*" [\w,]+\s*$)");
  std::map<std::string, DbcMessage> out;
  DbcMessage* current = nullptr;
  std::string line;
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_match(line, m, bo)) {
      current = &out[m[2]];
      current->id = static_cast<unsigned>(std::stoul(m[1]));
      current->dlc = std::stoi(m[3]);
    } else if (std::regex_match(line, m, sg)) {
      EXPECT_NE(current, nullptr) << line;
      if (current == nullptr) continue;
      DbcSignal s;
      s.start = std::stoi(m[2]);
      s.length = std::stoi(m[3]);
      s.little_endian = m[4] == "1";
      s.is_signed = m[5] == "-";
      s.scale = std::stod(m[6]);
      s.offset = std::stod(m[7]);
      s.min = std::stod(m[8]);
      s.max = std::stod(m[9]);
      current->signals[m[1]] = s;
    } else if (line.rfind(" SG_", 0) == 0 || line.rfind("BO_ ", 0) == 0) {
      ADD_FAILURE() << "unparsed DBC line: " << line;
    }
  }
  return out;
}

// Physical value of s in f, by the DBC's definition (little-endian bit numbering).
double Extract(const can_frame& f, const DbcSignal& s) {
  EXPECT_TRUE(s.little_endian);
  std::uint64_t raw = 0;
  for (int i = 0; i < s.length; ++i) {
    const int bit = s.start + i;
    if ((f.data[bit / 8] >> (bit % 8)) & 1U) raw |= std::uint64_t{1} << i;
  }
  auto v = static_cast<std::int64_t>(raw);
  if (s.is_signed && (raw >> (s.length - 1)) != 0) v -= std::int64_t{1} << s.length;
  return static_cast<double>(v) * s.scale + s.offset;
}

class DbcTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { dbc_ = LoadDbc(std::string(MRD_SOURCE_DIR) + "/docs/mrd.dbc"); }

  // Every signal of message `name` equals its expected value (within half a count).
  void Check(const std::string& name, canid_t id, const can_frame& f,
             const std::map<std::string, double>& expected) {
    ASSERT_TRUE(dbc_.count(name) == 1) << name << " not in the DBC";
    const DbcMessage& m = dbc_.at(name);
    EXPECT_EQ(m.id, id) << name;
    EXPECT_EQ(f.can_id, id) << name;
    EXPECT_EQ(m.dlc, f.len) << name;
    EXPECT_EQ(m.signals.size(), expected.size()) << name << ": signal sets differ";
    for (const auto& [sig, value] : expected) {
      ASSERT_TRUE(m.signals.count(sig) == 1) << name << "." << sig << " not in the DBC";
      const DbcSignal& s = m.signals.at(sig);
      EXPECT_NEAR(Extract(f, s), value, 0.5 * s.scale) << name << "." << sig;
    }
  }
  const DbcSignal& Signal(const std::string& msg, const std::string& sig) {
    return dbc_.at(msg).signals.at(sig);
  }

  static std::map<std::string, DbcMessage> dbc_;
};
std::map<std::string, DbcMessage> DbcTest::dbc_;

// The built-in codec's seven messages, FirmwareTelemetry (live telemetry, sent through the
// mrd-native profile's codec; its values are checked by tests/fieldbus/telemetry_test.py) and
// SensorChassis (the chassis laws' inputs) and SensorStructure (the clipped-optimal law's floor
// accelerations), through the profile's codec only.
TEST_F(DbcTest, TheDbcHoldsExactlyTheCodecsMessages) {
  EXPECT_EQ(dbc_.size(), 10U);
  EXPECT_EQ(dbc_.count("FirmwareTelemetry"), 1U);
  EXPECT_EQ(dbc_.count("SensorChassis"), 1U);
  EXPECT_EQ(dbc_.count("SensorStructure"), 1U);
}

// Issue 10: the lockstep time grant (48-bit microseconds).
TEST_F(DbcTest, TimeGrantMatches) {
  can_frame f{};
  const std::uint64_t t = 123'456'789'012ULL;
  ASSERT_EQ(Encode(TimeGrant{t, 11}, &f), Reject::kNone);
  Check("TimeGrant", kTimeGrantId, f,
        {{"GrantTime", static_cast<double>(t)},
         {"GrantCounter", 11},
         {"GrantChecksum", Checksum(f)}});
  TimeGrant back;
  ASSERT_EQ(Decode(f, &back), Reject::kNone);
  EXPECT_EQ(back.time_us, t);
  EXPECT_EQ(back.counter, 11);
  EXPECT_EQ(Classify(f), Message::kTimeGrant);
  f.data[2] ^= 0x40U;
  EXPECT_EQ(Decode(f, &back), Reject::kBadChecksum);
  EXPECT_EQ(Encode(TimeGrant{kMaxGrantUs + 1, 0}, &f), Reject::kOutOfRange);
}

TEST_F(DbcTest, SensorFramesMatch) {
  can_frame f{};
  ASSERT_EQ(Encode(SensorMotion{-123.45, 17.891, 65000, 13}, &f), Reject::kNone);
  Check("SensorMotion", kSensorMotionId, f,
        {{"Velocity", -123.45},
         {"Displacement", 17.891},
         {"SensorSeq", 65000},
         {"MotionCounter", 13},
         {"MotionChecksum", Checksum(f)}});
  ASSERT_EQ(Encode(SensorForce{-14999.5, 299.99, 1234.5, 1}, &f), Reject::kNone);
  Check("SensorForce", kSensorForceId, f,
        {{"Demand", -14999.5},
         {"BodyVelocity", 299.99},
         {"Force", 1234.5},
         {"ForceCounter", 1},
         {"ForceChecksum", Checksum(f)}});
  EXPECT_DOUBLE_EQ(Signal("SensorMotion", "Velocity").max, kMaxVelocity);
  EXPECT_DOUBLE_EQ(Signal("SensorMotion", "Velocity").min, -kMaxVelocity);
  EXPECT_DOUBLE_EQ(Signal("SensorMotion", "Displacement").max, kMaxDisplacement);
  EXPECT_DOUBLE_EQ(Signal("SensorForce", "Force").max, kMaxForce);
  EXPECT_DOUBLE_EQ(Signal("SensorForce", "Demand").min, -kMaxForce);
}

TEST_F(DbcTest, DriverFramesMatch) {
  can_frame f{};
  ASSERT_EQ(Encode(DriverCommand{2.345, true, false, true, 513, 9}, &f), Reject::kNone);
  Check("DriverCommand", kDriverCommandId, f,
        {{"VoltageSetpoint", 2.345},
         {"Enable", 1},
         {"EnableValid", 0},
         {"SafeState", 1},
         {"EchoSeq", 513},
         {"CommandCounter", 9},
         {"CommandChecksum", Checksum(f)}});
  EXPECT_DOUBLE_EQ(Signal("DriverCommand", "VoltageSetpoint").max, kMaxVoltage);
  ASSERT_EQ(Encode(Heartbeat{true, 14}, &f), Reject::kNone);
  Check("Heartbeat", kHeartbeatId, f,
        {{"HeartbeatCounter", 14}, {"HeartbeatSafe", 1}, {"HeartbeatChecksum", Checksum(f)}});
  ASSERT_EQ(Encode(DriverStatus{9.876, kFaultUndervoltage | kFaultHeartbeatLost, 5}, &f),
            Reject::kNone);
  Check("DriverStatus", kDriverStatusId, f,
        {{"MeasuredCurrent", 9.876},
         {"DriverFaults", kFaultUndervoltage | kFaultHeartbeatLost},
         {"StatusCounter", 5},
         {"StatusChecksum", Checksum(f)}});
  EXPECT_DOUBLE_EQ(Signal("DriverStatus", "MeasuredCurrent").max, kMaxCurrent);
}

TEST_F(DbcTest, FirmwareStatusMatches) {
  can_frame f{};
  ASSERT_EQ(Encode(FirmwareStatus{true, 0x1C1, 1234, 56, 78}, &f), Reject::kNone);
  Check("FirmwareStatus", kFirmwareStatusId, f,
        {{"FirmwareSafe", 1},
         {"ActiveCauses", 0x1C1},
         {"Overruns", 1234},
         {"SafeEntries", 56},
         {"StatusSequence", 78}});
}

}  // namespace
}  // namespace mrd::protocol::can
