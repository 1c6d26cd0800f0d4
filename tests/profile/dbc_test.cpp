// The DBC subset parser (mrd::profile, dbc.hpp): the project's own docs/mrd.dbc, a DBC written
// by hand for a test driver (Motorola and Intel, offsets, signed values, an extended id), and
// every refusal with its file, line and reason.
#include "mrd/profile/dbc.hpp"

#include <gtest/gtest.h>

#include <string>

namespace mrd::profile {
namespace {

const std::string kSource = MRD_SOURCE_DIR;

TEST(DbcTest, ParsesTheNativeFrameSet) {
  Dbc dbc;
  std::string error;
  ASSERT_TRUE(LoadDbc(kSource + "/docs/mrd.dbc", &dbc, &error)) << error;
  ASSERT_EQ(dbc.messages.size(), 10U);
  // The structure sensors (clipped-optimal law): three floor accelerations, 0.001 m/s^2, 1 ms.
  const DbcMessage* structure = dbc.Find("SensorStructure");
  ASSERT_NE(structure, nullptr);
  EXPECT_EQ(structure->id, 0x104U);
  EXPECT_EQ(structure->cycle_time_ms, 1);
  for (const char* name : {"FloorAcceleration1", "FloorAcceleration2", "FloorAcceleration3"}) {
    ASSERT_NE(structure->Find(name), nullptr) << name;
    EXPECT_TRUE(structure->Find(name)->layout.is_signed) << name;
    EXPECT_DOUBLE_EQ(structure->Find(name)->layout.factor, 0.001) << name;
  }
  EXPECT_EQ(structure->Find("FloorAcceleration3")->layout.start_bit, 32);
  // The chassis sensors (groundhook, hybrid, add, sh-add laws): 0.1 cm/s^2, 0.01 cm/s, 1 ms.
  const DbcMessage* chassis = dbc.Find("SensorChassis");
  ASSERT_NE(chassis, nullptr);
  EXPECT_EQ(chassis->id, 0x103U);
  EXPECT_EQ(chassis->cycle_time_ms, 1);
  ASSERT_NE(chassis->Find("BodyAcceleration"), nullptr);
  EXPECT_TRUE(chassis->Find("BodyAcceleration")->layout.is_signed);
  EXPECT_DOUBLE_EQ(chassis->Find("BodyAcceleration")->layout.factor, 0.1);
  ASSERT_NE(chassis->Find("WheelVelocity"), nullptr);
  EXPECT_EQ(chassis->Find("WheelVelocity")->layout.start_bit, 16);
  EXPECT_DOUBLE_EQ(chassis->Find("WheelVelocity")->layout.factor, 0.01);
  // Live telemetry (docs/telemetry.md): signed 0.5 N forces, a 1 mV command, 100 ms.
  const DbcMessage* tel = dbc.Find("FirmwareTelemetry");
  ASSERT_NE(tel, nullptr);
  EXPECT_EQ(tel->id, 0x301U);
  EXPECT_EQ(tel->cycle_time_ms, 100);
  ASSERT_NE(tel->Find("ModelForce"), nullptr);
  EXPECT_TRUE(tel->Find("ModelForce")->layout.is_signed);
  EXPECT_DOUBLE_EQ(tel->Find("ForceDemand")->layout.factor, 0.5);
  EXPECT_EQ(tel->Find("CommandVoltage")->layout.start_bit, 32);
  EXPECT_DOUBLE_EQ(tel->Find("CommandVoltage")->layout.factor, 0.001);
  const DbcMessage* cmd = dbc.Find("DriverCommand");
  ASSERT_NE(cmd, nullptr);
  EXPECT_EQ(cmd->id, 0x080U);
  EXPECT_FALSE(cmd->extended);
  EXPECT_EQ(cmd->dlc, 8);
  EXPECT_EQ(cmd->cycle_time_ms, 1);
  const DbcSignal* sp = cmd->Find("VoltageSetpoint");
  ASSERT_NE(sp, nullptr);
  EXPECT_EQ(sp->layout.start_bit, 0);
  EXPECT_EQ(sp->layout.length, 16);
  EXPECT_EQ(sp->layout.order, protocol::ByteOrder::kIntel);
  EXPECT_FALSE(sp->layout.is_signed);
  EXPECT_DOUBLE_EQ(sp->layout.factor, 0.001);
  EXPECT_DOUBLE_EQ(sp->layout.max, 24.0);
  EXPECT_EQ(sp->unit, "V");
  const DbcMessage* motion = dbc.Find("SensorMotion");
  ASSERT_NE(motion, nullptr);
  EXPECT_TRUE(motion->Find("Velocity")->layout.is_signed);
  EXPECT_EQ(dbc.Find("Heartbeat")->dlc, 2);
  EXPECT_EQ(dbc.Find("Heartbeat")->cycle_time_ms, 10);
  EXPECT_EQ(dbc.Find("TimeGrant")->Find("GrantTime")->layout.length, 48);
}

constexpr const char* kDriverDbc = R"(VERSION ""

NS_ :
	CM_
	BA_DEF_

BS_:
BU_: Ctrl Drive

BO_ 2566834709 DriveStatus: 8 Drive
 SG_ Current : 7|12@0+ (0.01,0) [0|40.95] "A" Ctrl
 SG_ Temperature : 11|8@0- (0.5,-20) [-84|43.5] "degC" Ctrl
 SG_ Faults : 32|8@1+ (1,0) [0|255] "" Ctrl
 SG_ Counter : 52|4@1+ (1,0) [0|15] "" Ctrl

BO_ 512 DriveCommand: 4 Ctrl
 SG_ CurrentSetpoint : 0|16@1- (0.001,0.5) [-32|32] "A" Drive
 SG_ Enable : 23|1@0+ (1,0) [0|1] "" Drive

CM_ BO_ 512 "A comment
over two lines; with a semicolon inside";
BA_DEF_ BO_ "GenMsgCycleTime" INT 0 65535;
BA_ "GenMsgCycleTime" BO_ 512 2;
BA_ "GenMsgCycleTime" BO_ 2566834709 20;
VAL_ 512 Enable 0 "off" 1 "on" ;
)";

TEST(DbcTest, ParsesAHandWrittenDriverDbc) {
  Dbc dbc;
  std::string error;
  ASSERT_TRUE(ParseDbc(kDriverDbc, "driver.dbc", &dbc, &error)) << error;
  ASSERT_EQ(dbc.messages.size(), 2U);
  const DbcMessage* st = dbc.Find("DriveStatus");
  ASSERT_NE(st, nullptr);
  EXPECT_TRUE(st->extended);
  EXPECT_EQ(st->id, 2566834709U - 0x80000000U);
  EXPECT_EQ(st->cycle_time_ms, 20);
  EXPECT_EQ(st->Find("Temperature")->layout.order, protocol::ByteOrder::kMotorola);
  EXPECT_TRUE(st->Find("Temperature")->layout.is_signed);
  EXPECT_DOUBLE_EQ(st->Find("Temperature")->layout.offset, -20.0);
  const DbcMessage* cmd = dbc.Find("DriveCommand");
  EXPECT_EQ(cmd->cycle_time_ms, 2);
  EXPECT_EQ(cmd->dlc, 4);
  // Known answers: Current 0x123 * 0.01 = 2.91 A from bytes 0x12, 0x3_ (Motorola).
  std::uint8_t d[8] = {0x12, 0x30, 0, 0, 0x05, 0, 0, 0};
  double v = 0;
  EXPECT_EQ(protocol::DecodeSignal(d, st->Find("Current")->layout, &v),
            protocol::SignalError::kNone);
  EXPECT_NEAR(v, 2.91, 1e-12);
  EXPECT_EQ(protocol::DecodeSignal(d, st->Find("Faults")->layout, &v),
            protocol::SignalError::kNone);
  EXPECT_EQ(v, 5.0);
}

// One refusal: the text fails to parse with "FILE:LINE: <reason>".
void ExpectRefused(const std::string& text, int line, const std::string& reason) {
  Dbc dbc;
  std::string error;
  EXPECT_FALSE(ParseDbc(text, "bad.dbc", &dbc, &error)) << text;
  EXPECT_EQ(error.rfind("bad.dbc:" + std::to_string(line) + ": ", 0), 0U) << error;
  EXPECT_NE(error.find(reason), std::string::npos) << error;
}

TEST(DbcTest, RefusesWhatItCannotUseWithFileLineAndReason) {
  const std::string bo = "BO_ 256 M: 8 N\n";
  ExpectRefused(bo + " SG_ A : 60|8@1+ (1,0) [0|0] \"\" X\n", 2, "does not fit");
  ExpectRefused("BO_ 256 M: 2 N\n SG_ A : 7|24@0+ (1,0) [0|0] \"\" X\n", 2, "does not fit");
  ExpectRefused(bo + " SG_ A : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ B : 4|8@1+ (1,0) [0|0] \"\" X\n", 3,
                "overlaps A (line 2)");
  ExpectRefused(bo + " SG_ A : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ A : 8|8@1+ (1,0) [0|0] \"\" X\n", 3,
                "defined twice");
  ExpectRefused(bo + " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" X\n", 2, "multiplexed");
  ExpectRefused(bo + " SG_ A : 0|8@2+ (1,0) [0|0] \"\" X\n", 2, "byte order");
  ExpectRefused(bo + " SG_ A : 0|8@1+ (0,0) [0|0] \"\" X\n", 2, "factor 0");
  ExpectRefused(bo + " SG_ A : 0|8@1+ (1,0) [5|1] \"\" X\n", 2, "min > max");
  ExpectRefused(bo + " SG_ A : 0|0@1+ (1,0) [0|0] \"\" X\n", 2, "length 0 bits");
  ExpectRefused(bo + " SG_ A : 0|8@1+ (1,0) [0|0] X\n", 2, "unit");
  ExpectRefused("BO_ 256 M: 9 N\n", 1, "length 9 bytes");
  ExpectRefused("BO_ 2048 M: 8 N\n", 1, "beyond 11 bits");
  ExpectRefused(bo + "BO_ 257 M: 8 N\n", 2, "defined twice (first at line 1)");
  ExpectRefused(bo + "BO_ 256 K: 8 N\n", 2, "has the id of M");
  ExpectRefused(" SG_ A : 0|8@1+ (1,0) [0|0] \"\" X\n", 1, "outside a message");
  ExpectRefused(bo + "\nBA_ \"GenMsgCycleTime\" BO_ 999 10;\n", 3, "which no BO_ defines");
  ExpectRefused(bo + "CM_ BO_ 256 \"never closed\n", 2, "without its closing ';'");
  ExpectRefused(bo + "SIG_VALTYPE_ 256 A : 1;\n", 2, "float signals");
  ExpectRefused(bo + "what is this\n", 2, "unexpected text");
  // A statement that lacks its ';' is refused at its own line, not read on into the statements
  // after it (which it would swallow: a signal, a cycle time).
  ExpectRefused(bo + "BA_ \"GenMsgCycleTime\" BO_ 256 10\nBO_ 257 K: 8 N\n", 2,
                "BA_ statement without its closing ';' (line 3 begins the next statement)");
  ExpectRefused(bo + "VAL_ 256 A 0 \"off\" 1 \"on\"\n SG_ B : 0|8@1+ (1,0) [0|0] \"\" X\n", 2,
                "VAL_ statement without its closing ';'");
  ExpectRefused(bo + "BA_ \"GenMsgCycleTime\" BO_ 256 10\nCM_ \"x\";\n", 2,
                "without its closing ';' (line 3");
}

TEST(DbcTest, StatementsThatSpanLinesAndAByteOrderMarkAreRead) {
  Dbc dbc;
  std::string error;
  // A comment's text may span lines; a value table may continue on the next line.
  const std::string text =
      "\xEF\xBB\xBFVERSION \"\"\nBO_ 256 M: 8 N\n SG_ A : 0|8@1+ (1,0) [0|0] \"\" X\n"
      "CM_ SG_ 256 A \"two\nlines\";\nVAL_ 256 A 0 \"off\"\n  1 \"on\" ;\n"
      "BA_ \"GenMsgCycleTime\" BO_ 256 10;\n";
  ASSERT_TRUE(ParseDbc(text, "bom.dbc", &dbc, &error)) << error;
  ASSERT_EQ(dbc.messages.size(), 1U);
  EXPECT_EQ(dbc.messages[0].cycle_time_ms, 10);
  EXPECT_EQ(dbc.messages[0].signals.size(), 1U);
}

TEST(DbcTest, LoadRefusesWhatIsNotARegularFile) {
  Dbc dbc;
  std::string error;
  EXPECT_FALSE(LoadDbc("/nonexistent.dbc", &dbc, &error));
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
  EXPECT_FALSE(LoadDbc("/tmp", &dbc, &error));
  EXPECT_NE(error.find("not a regular file"), std::string::npos) << error;
}

}  // namespace
}  // namespace mrd::profile
