// Loading a CAN device profile (mrd::profile, can_profile.hpp): roles resolved against the
// DBC, message protection and timing, the checksum function against the native frame codec,
// and every refusal with file, line and reason.
#include "mrd/profile/can_profile.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "mrd/profile/frame_codec.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::profile {
namespace {

const std::string kSource = MRD_SOURCE_DIR;

// A profile file in a temporary directory next to a copy of docs/mrd.dbc.
class ProfileFile {
 public:
  explicit ProfileFile(const std::string& text) {
    char dir[] = "/tmp/mrd-profile-XXXXXX";
    dir_ = mkdtemp(dir);
    std::ifstream in(kSource + "/docs/mrd.dbc");
    std::ofstream(dir_ + "/mrd.dbc") << in.rdbuf();
    std::ofstream(path()) << text;
  }
  ~ProfileFile() {
    unlink(path().c_str());
    unlink((dir_ + "/mrd.dbc").c_str());
    rmdir(dir_.c_str());
  }
  std::string path() const { return dir_ + "/p.toml"; }

 private:
  std::string dir_;
};

constexpr const char* kNative = R"(name = "native-test"
dbc = "mrd.dbc"
[inputs]
velocity = "SensorMotion.Velocity"
sensor_seq = "SensorMotion.SensorSeq"
demand = "SensorForce.Demand"
[outputs]
command = "DriverCommand.VoltageSetpoint"
safe = "DriverCommand.SafeState"
[messages.SensorMotion]
counter = "MotionCounter"
checksum = "MotionChecksum"
checksum_kind = "crc8"
timeout_ms = 5
[messages.DriverCommand]
counter = "CommandCounter"
checksum = "CommandChecksum"
checksum_kind = "crc8"
crc_poly = 0x1D
crc_init = 0xFF
crc_xor = 0xFF
)";

TEST(CanProfileTest, ResolvesRolesAndMessages) {
  ProfileFile f(kNative);
  CanProfile p;
  std::string error;
  ASSERT_TRUE(LoadCanProfile(f.path(), &p, &error)) << error;
  EXPECT_EQ(p.name, "native-test");
  const SignalRef v = p.inputs[static_cast<std::size_t>(CanIn::kVelocity)];
  ASSERT_TRUE(v.mapped());
  EXPECT_EQ(p.dbc.messages[static_cast<std::size_t>(v.message)].name, "SensorMotion");
  EXPECT_DOUBLE_EQ(p.Layout(v).factor, 0.01);
  EXPECT_FALSE(p.inputs[static_cast<std::size_t>(CanIn::kForce)].mapped());
  const MessageSpec& motion = p.specs[static_cast<std::size_t>(v.message)];
  EXPECT_TRUE(motion.receive);
  EXPECT_FALSE(motion.transmit);
  EXPECT_EQ(motion.timeout_ns, 5'000'000);
  EXPECT_EQ(motion.checksum_kind, ChecksumKind::kCrc8);
  const SignalRef cmd = p.outputs[static_cast<std::size_t>(CanOut::kCommand)];
  const MessageSpec& command = p.specs[static_cast<std::size_t>(cmd.message)];
  EXPECT_TRUE(command.transmit);
  EXPECT_EQ(command.period_ns, 1'000'000);  // GenMsgCycleTime
}

// The profile's checksum function gives the native codec's CRC-8 on every sealed frame.
TEST(CanProfileTest, Crc8OverIdAndPayloadEqualsTheNativeCodec) {
  ProfileFile f(kNative);
  CanProfile p;
  std::string error;
  ASSERT_TRUE(LoadCanProfile(f.path(), &p, &error)) << error;
  const SignalRef v = p.inputs[static_cast<std::size_t>(CanIn::kVelocity)];
  const MessageSpec& spec = p.specs[static_cast<std::size_t>(v.message)];
  const auto& msg = p.dbc.messages[static_cast<std::size_t>(v.message)];
  const auto& ck = msg.signals[static_cast<std::size_t>(spec.checksum)].layout;
  for (int k = 0; k < 200; ++k) {
    can_frame fr{};
    ASSERT_EQ(protocol::can::Encode(protocol::can::SensorMotion{k * 0.37 - 30.0, k * 0.01 - 1.0,
                                                                static_cast<std::uint16_t>(k * 331),
                                                                static_cast<std::uint8_t>(k & 15)},
                                    &fr),
              protocol::can::Reject::kNone);
    EXPECT_EQ(FrameChecksum(spec, ck, msg.id, fr.data, msg.dlc), fr.data[7]) << k;
  }
  MessageSpec sum = spec;
  sum.checksum_kind = ChecksumKind::kSum8;
  sum.checksum_covers_id = false;
  const std::uint8_t d[8] = {1, 2, 3, 250, 5, 6, 7, 99};
  EXPECT_EQ(FrameChecksum(sum, ck, msg.id, d, 8),
            static_cast<std::uint8_t>(1 + 2 + 3 + 250 + 5 + 6 + 7));
}

void ExpectRefused(const std::string& text, int line, const std::string& reason) {
  ProfileFile f(text);
  CanProfile p;
  std::string error;
  EXPECT_FALSE(LoadCanProfile(f.path(), &p, &error)) << text;
  EXPECT_EQ(error.rfind(f.path() + ":" + std::to_string(line) + ": ", 0), 0U) << error;
  EXPECT_NE(error.find(reason), std::string::npos) << error;
}

TEST(CanProfileTest, RefusesBadProfilesWithFileLineAndReason) {
  const std::string head = "name = \"x\"\ndbc = \"mrd.dbc\"\n";
  ExpectRefused("name = \"x\"\n", 1, "dbc: expected");
  ExpectRefused(head + "[inputs]\nvelocity = \"SensorMotion.Speed\"\n", 4, "has no signal Speed");
  ExpectRefused(head + "[inputs]\nvelocity = \"Motion.Velocity\"\n", 4, "has no message Motion");
  ExpectRefused(head + "[inputs]\nvelocity = \"Velocity\"\n", 4, "is not Message.Signal");
  ExpectRefused(head + "[inputs]\nspeed = \"SensorMotion.Velocity\"\n", 4, "unknown role");
  ExpectRefused(head +
                    "[inputs]\ndemand = \"SensorMotion.Velocity\"\n"
                    "velocity = \"SensorMotion.Velocity\"\n",
                5, "already carries inputs.demand");
  ExpectRefused(head +
                    "[inputs]\nvelocity = \"SensorMotion.Velocity\"\n[outputs]\n"
                    "command = \"SensorMotion.Displacement\"\n",
                6, "both sent and received");
  ExpectRefused(head +
                    "[inputs]\nvelocity = \"SensorMotion.Velocity\"\n"
                    "[messages.SensorMotion]\ncounter = \"Velocity\"\n",
                6, "carries the role velocity");
  ExpectRefused(head + "[messages.SensorMotion]\ncounter = \"SensorSeq\"\n", 4, "at most 8 bits");
  ExpectRefused(
      head + "[messages.SensorMotion]\nchecksum = \"MotionCounter\"\nchecksum_kind = \"crc8\"\n", 4,
      "unsigned 8-bit signal");
  ExpectRefused(head + "[messages.SensorMotion]\nchecksum = \"MotionChecksum\"\n", 3,
                "go together");
  ExpectRefused(head + "[messages.SensorMotion]\nchecksum_kind = \"crc16\"\n", 4,
                "expected \"crc8\"");
  ExpectRefused(head + "[messages.SensorMotion]\ncrc_poly = 300\n", 4, "0..255");
  ExpectRefused(head + "[messages.SensorMotion]\nperiod_ms = 0\n", 4, "milliseconds");
  ExpectRefused(head + "[messages.SensorMotion]\nspeed = 1\n", 4, "unknown key");
  ExpectRefused(head + "[messages.Nothing]\n", 3, "has no message Nothing");
  ExpectRefused(head + "colour = 1\n", 3, "unknown key");
  ExpectRefused("dbc = \"mrd.dbc\"\n", 1, "name: missing");
  ExpectRefused(head + "[inputs\n", 3, "");  // TOML syntax: the parser's own words
  // [command] beyond what the set-point signal carries (VoltageSetpoint: 0..24 V in the DBC):
  // the safe state would stand in for every command above it.
  const std::string command = head + "[outputs]\ncommand = \"DriverCommand.VoltageSetpoint\"\n";
  ExpectRefused(command + "[command]\nmin = 0.0\nmax = 30.0\n", 7,
                "command.max 30 V is beyond what DriverCommand.VoltageSetpoint");
  ExpectRefused(command + "[command]\nmin = -1.0\nmax = 20.0\n", 6, "command.min -1 V");
}

// A sensor frame whose only sample number is its rolling counter: the counter is sensor_seq.
TEST(CanProfileTest, ARollingCounterMayAlsoBeTheSensorSeq) {
  ProfileFile f(
      "name = \"x\"\ndbc = \"mrd.dbc\"\n[inputs]\nvelocity = \"SensorMotion.Velocity\"\n"
      "sensor_seq = \"SensorMotion.MotionCounter\"\n[messages.SensorMotion]\n"
      "counter = \"MotionCounter\"\nchecksum = \"MotionChecksum\"\nchecksum_kind = \"crc8\"\n");
  CanProfile p;
  std::string error;
  ASSERT_TRUE(LoadCanProfile(f.path(), &p, &error)) << error;
  const SignalRef seq = p.inputs[static_cast<std::size_t>(CanIn::kSensorSeq)];
  ASSERT_TRUE(seq.mapped());
  // Three frames: each accepted, its sensor_seq the counter (+1 mod 16 per frame).
  FrameCodec tx(p), rx(p);
  double first = -1;
  for (int k = 0; k < 3; ++k) {
    can_frame fr{};
    tx.Begin(seq.message, &fr);
    tx.Seal(seq.message, &fr);
    ASSERT_EQ(rx.Check(seq.message, fr), protocol::can::Reject::kNone) << k;
    double v = -1;
    ASSERT_EQ(rx.Get(fr, seq, &v), protocol::SignalError::kNone);
    if (k == 0) first = v;
    EXPECT_EQ(v, std::fmod(first + k, 16.0)) << k;
  }
  // Any other role on a counter is still refused (above).
}

TEST(CanProfileTest, AMissingOrBrokenDbcIsNamed) {
  CanProfile p;
  std::string error;
  ProfileFile missing("name = \"x\"\ndbc = \"nothere.dbc\"\n");
  EXPECT_FALSE(LoadCanProfile(missing.path(), &p, &error));
  EXPECT_NE(error.find("nothere.dbc: cannot open"), std::string::npos) << error;
  EXPECT_FALSE(LoadCanProfile("/tmp", &p, &error));
  EXPECT_NE(error.find("not a regular file"), std::string::npos) << error;
}

// docs/mrd.dbc with a FaultReset bit in DriverCommand (bit 19, free in the native layout) and
// one in the heartbeat message (bit 5).
std::string DbcWithResetBits() {
  std::ifstream in(kSource + "/docs/mrd.dbc");
  std::string dbc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto insert = [&](const std::string& after, const std::string& line) {
    const std::size_t at = dbc.find(after);
    EXPECT_NE(at, std::string::npos) << after;
    if (at != std::string::npos) dbc.insert(at + after.size(), line);
  };
  insert(" SG_ SafeState : 18|1@1+ (1,0) [0|1] \"\" Driver\n",
         " SG_ FaultReset : 19|1@1+ (1,0) [0|1] \"\" Driver\n");
  insert(" SG_ HeartbeatSafe : 4|1@1+ (1,0) [0|1] \"\" Driver\n",
         " SG_ HeartbeatReset : 5|1@1+ (1,0) [0|1] \"\" Driver\n");
  return dbc;
}

TEST(CanProfileTest, FaultResetIsABitOfACommandFrame) {
  const std::string dbc = DbcWithResetBits();
  const std::string head =
      "name = \"x\"\ndbc = \"mrd.dbc\"\n[inputs]\ndriver_faults = \"DriverStatus.DriverFaults\"\n"
      "[outputs]\ncommand = \"DriverCommand.VoltageSetpoint\"\n"
      "heartbeat_safe = \"Heartbeat.HeartbeatSafe\"\n";
  CanProfile p;
  std::string error;
  ASSERT_TRUE(ParseCanProfile(head + "fault_reset = \"DriverCommand.FaultReset\"\n", "p.toml", &dbc,
                              &p, &error))
      << error;
  const SignalRef r = p.outputs[static_cast<std::size_t>(CanOut::kFaultReset)];
  ASSERT_TRUE(r.mapped());
  EXPECT_EQ(r.message, p.outputs[static_cast<std::size_t>(CanOut::kCommand)].message);
  EXPECT_EQ(p.Layout(r).length, 1);
  EXPECT_STREQ(CanOutName(CanOut::kFaultReset), "fault_reset");
  // Refused at its line: not a bit, or a bit of a frame not sent every period.
  const auto refused = [&](const std::string& signal, const std::string& reason) {
    CanProfile q;
    std::string why;
    EXPECT_FALSE(
        ParseCanProfile(head + "fault_reset = \"" + signal + "\"\n", "p.toml", &dbc, &q, &why))
        << signal;
    EXPECT_EQ(why.rfind("p.toml:8: outputs.fault_reset: ", 0), 0U) << why;
    EXPECT_NE(why.find(reason), std::string::npos) << why;
  };
  refused("DriverCommand.EchoSeq", "expected a bit");
  refused("Heartbeat.HeartbeatReset", "is not a command frame");
  refused("FirmwareStatus.FirmwareSafe", "is not a command frame");
  // Without driver_faults the firmware never sees a fault to reset: refused at the role's line.
  std::string no_faults = head;
  no_faults.erase(no_faults.find("[inputs]"),
                  no_faults.find("[outputs]") - no_faults.find("[inputs]"));
  CanProfile q;
  std::string why;
  EXPECT_FALSE(ParseCanProfile(no_faults + "fault_reset = \"DriverCommand.FaultReset\"\n", "p.toml",
                               &dbc, &q, &why));
  EXPECT_EQ(why.rfind("p.toml:6: outputs.fault_reset: the profile maps no driver_faults", 0), 0U)
      << why;
}

}  // namespace
}  // namespace mrd::profile
