// Loading a Modbus device profile (mrd::profile, modbus_profile.hpp): the shipped
// modbus-float32 profile, read grouping (fewest requests), the typed codec with both word
// orders against values worked out by hand, and every refusal with file, line and reason.
#include "mrd/profile/modbus_profile.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <string>

namespace mrd::profile {
namespace {

const std::string kSource = MRD_SOURCE_DIR;

bool Parse(const std::string& text, ModbusProfile* p, std::string* error) {
  return ParseModbusProfile(text, "/tmp/t.toml", p, error);
}

// Refused, with this line and a reason containing `why`.
void ExpectRefused(const std::string& text, int line, const std::string& why) {
  ModbusProfile p;
  std::string error;
  ASSERT_FALSE(Parse(text, &p, &error)) << text;
  EXPECT_NE(error.find("/tmp/t.toml:" + std::to_string(line) + ":"), std::string::npos) << error;
  EXPECT_NE(error.find(why), std::string::npos) << error;
}

const std::string kHead = "name = \"t\"\n[modbus]\n";  // lines 1-2

// The four-corner maps (several channels on one link, docs/devices.md): each loads as a
// one-channel profile of its own; corner k's sensor block at unit 1 input 16 k, its set-point
// block at unit 2 holding 16 k, its enable coil k, the one grant register all four name.
TEST(ModbusProfile, ShippedCornerProfiles) {
  const char* corners[] = {"fl", "fr", "rl", "rr"};
  for (int k = 0; k < 4; ++k) {
    ModbusProfile p;
    std::string error;
    const std::string name = std::string("modbus-corner-") + corners[k];
    ASSERT_TRUE(LoadModbusProfile(kSource + "/firmware/profiles/" + name + ".toml", &p, &error))
        << error;
    EXPECT_EQ(p.name, name);
    EXPECT_TRUE(p.swapped);
    EXPECT_EQ(p.write_function, 16);
    EXPECT_EQ(p.max_read, 125);
    EXPECT_EQ(p.In(CanIn::kSensorSeq).address, 16 * k);
    EXPECT_EQ(p.In(CanIn::kVelocity).address, 16 * k + 2);
    EXPECT_EQ(p.In(CanIn::kDriverFaults).address, k);
    EXPECT_EQ(p.In(CanIn::kGrant).address, 64);
    EXPECT_EQ(p.Out(ModbusOut::kCommand).unit, 2);
    EXPECT_EQ(p.Out(ModbusOut::kCommand).address, 16 * k);
    EXPECT_EQ(p.Out(ModbusOut::kEnable).address, k);
    // The enable coil, the live telemetry block, then the command's holding block last.
    ASSERT_EQ(p.writes.size(), 3u);
    EXPECT_EQ(p.writes[0].function, 0x0F);
    EXPECT_EQ(p.writes[2].address, 16 * k);
  }
}

TEST(ModbusProfile, ShippedFloat32Profile) {
  ModbusProfile p;
  std::string error;
  ASSERT_TRUE(LoadModbusProfile(kSource + "/firmware/profiles/modbus-float32.toml", &p, &error))
      << error;
  EXPECT_EQ(p.name, "modbus-float32");
  EXPECT_TRUE(p.swapped);
  EXPECT_TRUE(p.align32);
  const ModbusPoint& v = p.In(CanIn::kVelocity);
  EXPECT_EQ(v.unit, 1);
  EXPECT_EQ(v.table, ModbusTable::kInput);
  EXPECT_EQ(v.type, ModbusType::kFloat32);
  EXPECT_TRUE(p.In(CanIn::kGrant).mapped);
  EXPECT_EQ(p.Out(ModbusOut::kCommand).unit, 2);
  EXPECT_EQ(p.Out(ModbusOut::kEnable).table, ModbusTable::kCoil);
  // Unit 1's input registers 0..15 in one 0x04 request, unit 2's status register in another.
  ASSERT_EQ(p.reads.size(), 2u);
  EXPECT_EQ(p.reads[0].unit, 1);
  EXPECT_EQ(p.reads[0].function, 0x04);
  EXPECT_EQ(p.reads[0].address, 0);
  EXPECT_EQ(p.reads[0].count, 16);
  EXPECT_EQ(p.reads[1].unit, 2);
  // The enable coil (0x0F), the live telemetry block (8..13: model force, demand, command),
  // then the holding block with the command (0x10) last.
  ASSERT_EQ(p.writes.size(), 3u);
  EXPECT_EQ(p.writes[0].function, 0x0F);
  EXPECT_EQ(p.writes[1].function, 0x10);
  EXPECT_EQ(p.writes[1].address, 8);
  EXPECT_EQ(p.writes[1].count, 6);
  EXPECT_EQ(p.Out(ModbusOut::kStatusModelForce).request, 1);
  EXPECT_EQ(p.Out(ModbusOut::kStatusCommand).index, 4);
  EXPECT_EQ(p.writes[2].function, 0x10);
  EXPECT_EQ(p.Out(ModbusOut::kCommand).request, 2);
  EXPECT_EQ(p.writes[2].count, 7);
  EXPECT_DOUBLE_EQ(p.command.max(), 24.0);
}

TEST(ModbusProfile, GroupsReadsIntoFewestRequests) {
  // Unit 1 holding: 0-1, 4 (gap 2: bridged), 30-31 and 33 (gap 25: a new request); the input
  // table apart;
  // unit 3 coils 0 and 7 (one request); max_read 10 splits 40..49 from 52.
  const std::string text =
      kHead +
      "max_read = 10\n[modbus.inputs]\n"
      "velocity = { unit = 1, table = \"holding\", address = 0, type = \"float32\" }\n"
      "displacement = { unit = 1, table = \"holding\", address = 4, type = \"int16\" }\n"
      "demand = { unit = 1, table = \"holding\", address = 30, type = \"int32\" }\n"
      "force = { unit = 1, table = \"input\", address = 0 }\n"
      "fault_line = { unit = 3, table = \"coil\", address = 0 }\n"
      "driver_faults = { unit = 3, table = \"coil\", address = 7 }\n"
      "body_velocity = { unit = 1, table = \"holding\", address = 33 }\n"
      "sensor_seq = { unit = 4, table = \"holding\", address = 40 }\n"
      "driver_current = { unit = 4, table = \"holding\", address = 49 }\n"
      "grant = { unit = 4, table = \"holding\", address = 52, type = \"uint32\" }\n";
  ModbusProfile p;
  std::string error;
  ASSERT_TRUE(Parse(text, &p, &error)) << error;
  ASSERT_EQ(p.reads.size(), 6u);
  const auto expect = [&](std::size_t i, int unit, int fc, int address, int count) {
    EXPECT_EQ(p.reads[i].unit, unit) << i;
    EXPECT_EQ(p.reads[i].function, fc) << i;
    EXPECT_EQ(p.reads[i].address, address) << i;
    EXPECT_EQ(p.reads[i].count, count) << i;
  };
  expect(0, 1, 0x03, 0, 5);   // velocity, displacement
  expect(1, 1, 0x03, 30, 4);  // demand (30-31), body_velocity (33: gap 1)
  expect(2, 1, 0x04, 0, 1);
  expect(3, 3, 0x01, 0, 8);
  expect(4, 4, 0x03, 40, 10);
  expect(5, 4, 0x03, 52, 2);
  EXPECT_EQ(p.In(CanIn::kDisplacement).request, 0);
  EXPECT_EQ(p.In(CanIn::kDisplacement).index, 4);
  EXPECT_EQ(p.In(CanIn::kDriverFaults).index, 7);
}

// The chassis roles (groundhook, hybrid, add, sh-add laws) map like any input; a firmware
// [modbus] section routes them through the profile (the built-in map has none).
TEST(ModbusProfile, MapsTheChassisRoles) {
  const std::string text =
      kHead +
      "[modbus.inputs]\n"
      "velocity = { unit = 1, table = \"input\", address = 0, type = \"float32\" }\n"
      "body_acceleration = { unit = 1, table = \"input\", address = 2, type = \"float32\" }\n"
      "wheel_velocity = { unit = 1, table = \"input\", address = 4, type = \"float32\" }\n";
  ModbusProfile p;
  std::string error;
  ASSERT_TRUE(Parse(text, &p, &error)) << error;
  EXPECT_TRUE(p.In(CanIn::kBodyAcceleration).mapped);
  EXPECT_EQ(p.In(CanIn::kBodyAcceleration).index, 2);
  EXPECT_TRUE(p.In(CanIn::kWheelVelocity).mapped);
  EXPECT_EQ(p.In(CanIn::kWheelVelocity).index, 4);
  EXPECT_FALSE(p.In(CanIn::kSensorSeq).mapped);
  ASSERT_EQ(p.reads.size(), 1u);
  EXPECT_EQ(p.reads[0].count, 6);
}

TEST(ModbusProfile, WritesSingleRegisterWithFunction6) {
  const std::string text =
      kHead +
      "write_function = 6\n[modbus.outputs]\n"
      "command = { unit = 2, table = \"holding\", address = 0, type = \"int16\", scale = 0.001 }\n"
      "heartbeat = { unit = 2, table = \"holding\", address = 1 }\n"
      "enable = { unit = 2, table = \"coil\", address = 3 }\n";
  ModbusProfile p;
  std::string error;
  ASSERT_TRUE(Parse(text, &p, &error)) << error;
  ASSERT_EQ(p.writes.size(), 3u);
  EXPECT_EQ(p.writes[0].function, 0x05);  // the coil
  EXPECT_EQ(p.writes[1].function, 0x06);  // heartbeat
  EXPECT_EQ(p.writes[2].function, 0x06);  // command last
  EXPECT_EQ(p.writes[2].address, 0);
  EXPECT_EQ(p.Out(ModbusOut::kCommand).request, 2);
  EXPECT_EQ(p.Out(ModbusOut::kHeartbeat).request, 1);
  std::uint16_t words[1] = {};
  ASSERT_TRUE(PutModbusPoint(p, p.Out(ModbusOut::kCommand), -1.5, words));
  std::uint8_t pdu[8];
  ASSERT_EQ(PutModbusWrite(p.writes[2], words, pdu), 5);
  const std::uint8_t want[5] = {0x06, 0x00, 0x00, 0xFA, 0x24};  // -1500 = 0xFA24
  EXPECT_EQ(std::memcmp(pdu, want, 5), 0);
  std::uint16_t on[1] = {1};
  ASSERT_EQ(PutModbusWrite(p.writes[0], on, pdu), 5);
  const std::uint8_t coil[5] = {0x05, 0x00, 0x03, 0xFF, 0x00};
  EXPECT_EQ(std::memcmp(pdu, coil, 5), 0);
  // The reply echoes the request; anything else is malformed.
  std::uint8_t ex = 0;
  EXPECT_EQ(CheckModbusWrite(p.writes[0], coil, coil, 5, &ex), ModbusReply::kOk);
  const std::uint8_t other[5] = {0x05, 0x00, 0x04, 0xFF, 0x00};
  EXPECT_EQ(CheckModbusWrite(p.writes[0], coil, other, 5, &ex), ModbusReply::kMalformed);
  const std::uint8_t exc[2] = {0x85, 0x02};
  EXPECT_EQ(CheckModbusWrite(p.writes[0], coil, exc, 2, &ex), ModbusReply::kException);
  EXPECT_EQ(ex, 0x02);
}

// A driver whose manual orders its points differently: an int32 set-point low word first, a
// float32 current high word first, in one profile (the point's word_order over the profile's).
TEST(ModbusProfile, WordOrderPerPoint) {
  const std::string text = kHead +
                           "word_order = \"swapped\"\n[modbus.inputs]\n"
                           "driver_current = { unit = 2, table = \"input\", address = 0, type = "
                           "\"float32\", word_order = \"big\" }\n"
                           "[modbus.outputs]\ncommand = { unit = 2, table = \"holding\", "
                           "address = 0, type = \"int32\", scale = 0.001 }\n";
  ModbusProfile p;
  std::string error;
  ASSERT_TRUE(Parse(text, &p, &error)) << error;
  EXPECT_FALSE(p.In(CanIn::kDriverCurrent).swapped);
  EXPECT_TRUE(p.Out(ModbusOut::kCommand).swapped);
  // 1.0078f = 0x3F80FF97 high word first: read as such (swapped it would be a NaN's words).
  std::uint8_t reply[6] = {0x04, 4, 0x3F, 0x80, 0xFF, 0x97};
  EXPECT_NEAR(ModbusPointValue(p, p.In(CanIn::kDriverCurrent), reply), 1.0078, 1e-6);
  // 1.5 A as 1500 mA-steps: low word first.
  std::uint16_t words[2] = {};
  ASSERT_TRUE(PutModbusPoint(p, p.Out(ModbusOut::kCommand), 1.5, words));
  EXPECT_EQ(words[0], 1500);
  EXPECT_EQ(words[1], 0);
}

TEST(ModbusProfile, Float32BothWordOrders) {
  for (const bool swapped : {false, true}) {
    const std::string text = kHead + (swapped ? "word_order = \"swapped\"\n" : "") +
                             "[modbus.inputs]\nvelocity = { unit = 1, table = \"input\", address = "
                             "0, type = \"float32\" }\n"
                             "demand = { unit = 1, table = \"input\", address = 2, type = "
                             "\"int32\", scale = 0.01, offset = 5 }\n";
    ModbusProfile p;
    std::string error;
    ASSERT_TRUE(Parse(text, &p, &error)) << error;
    ASSERT_EQ(p.reads.size(), 1u);
    std::uint8_t req[5];
    ASSERT_EQ(PutModbusRead(p.reads[0], req), 5);
    const std::uint8_t want_req[5] = {0x04, 0, 0, 0, 4};
    EXPECT_EQ(std::memcmp(req, want_req, 5), 0);
    // 1.5f = 0x3FC00000; -100 raw = 0xFFFFFF9C.
    std::uint8_t reply[10] = {0x04, 8};
    const std::uint8_t abcd[8] = {0x3F, 0xC0, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0x9C};
    const std::uint8_t cdab[8] = {0x00, 0x00, 0x3F, 0xC0, 0xFF, 0x9C, 0xFF, 0xFF};
    std::memcpy(reply + 2, swapped ? cdab : abcd, 8);
    std::uint8_t ex = 0;
    ASSERT_EQ(CheckModbusRead(p.reads[0], reply, 10, &ex), ModbusReply::kOk);
    EXPECT_EQ(CheckModbusRead(p.reads[0], reply, 9, &ex), ModbusReply::kMalformed);
    EXPECT_DOUBLE_EQ(ModbusPointValue(p, p.In(CanIn::kVelocity), reply), 1.5);
    EXPECT_DOUBLE_EQ(ModbusPointValue(p, p.In(CanIn::kDemand), reply), -1.0 + 5.0);
    std::uint16_t store[4] = {};
    ASSERT_TRUE(StoreModbusPoint(p, p.In(CanIn::kVelocity), 1.5, store));
    EXPECT_EQ(store[0], swapped ? 0x0000 : 0x3FC0);
    EXPECT_EQ(store[1], swapped ? 0x3FC0 : 0x0000);
    EXPECT_DOUBLE_EQ(LoadModbusPoint(p, p.In(CanIn::kVelocity), store), 1.5);
    // Never wrapped: a value its type cannot hold, or a non-finite one, is refused.
    EXPECT_FALSE(StoreModbusPoint(p, p.In(CanIn::kDemand), 5.0 + 0.01 * 2147483648.0, store));
    EXPECT_FALSE(StoreModbusPoint(p, p.In(CanIn::kVelocity), NAN, store));
    EXPECT_FALSE(StoreModbusPoint(p, p.In(CanIn::kVelocity), 1e39, store));
  }
}

TEST(ModbusProfile, CoilsPackedLsbFirst) {
  const std::string text = kHead +
                           "[modbus.outputs]\n"
                           "enable = { unit = 2, table = \"coil\", address = 8 }\n"
                           "safe = { unit = 2, table = \"coil\", address = 9 }\n";
  ModbusProfile p;
  std::string error;
  ASSERT_TRUE(Parse(text, &p, &error)) << error;
  ASSERT_EQ(p.writes.size(), 1u);
  std::uint16_t words[2] = {};
  ASSERT_TRUE(PutModbusPoint(p, p.Out(ModbusOut::kSafe), 1.0, words));
  std::uint8_t pdu[16];
  ASSERT_EQ(PutModbusWrite(p.writes[0], words, pdu), 7);
  const std::uint8_t want[7] = {0x0F, 0, 8, 0, 2, 1, 0x02};
  EXPECT_EQ(std::memcmp(pdu, want, 7), 0);
}

TEST(ModbusProfile, Refusals) {
  const std::string in = kHead + "[modbus.inputs]\n";  // roles from line 4
  const std::string out = kHead + "[modbus.outputs]\n";
  ExpectRefused(kHead + "colour = 1\n", 3, "unknown key");
  ExpectRefused("name = \"t\"\nflavour = 1\n[modbus]\n", 2, "unknown key");
  ExpectRefused("name = \"t\"\n", 1, "[modbus]");
  ExpectRefused("[modbus]\n", 1, "name: missing");
  ExpectRefused(in + "speed = { unit = 1, table = \"input\", address = 0 }\n", 4, "unknown role");
  ExpectRefused(out + "velocity = { unit = 1, table = \"holding\", address = 0 }\n", 4,
                "unknown role");
  ExpectRefused(in + "velocity = { unit = 1, table = \"file\", address = 0 }\n", 4,
                "unknown table");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\", address = 0, type = \"f64\" }\n", 4,
                "unknown type");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\", address = 0, colour = 1 }\n", 4,
                "unknown key");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\", address = 0 }\n"
                     "velocity = { unit = 1, table = \"input\", address = 4 }\n",
                5, "velocity");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\", address = 0, type = \"float32\" }\n"
                     "demand = { unit = 1, table = \"input\", address = 1 }\n",
                5, "register 1 of unit 1 already carries modbus.inputs.velocity");
  ExpectRefused(in + "velocity = { unit = 1, table = \"holding\", address = 6 }\n" +
                    "[modbus.outputs]\n" +
                    "command = { unit = 1, table = \"holding\", address = 5, type = \"int32\" }\n",
                6, "already carries");
  ExpectRefused(
      in + "velocity = { unit = 1, table = \"input\", address = 65535, type = \"int32\" }\n", 4,
      "beyond 65535");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\", address = 65536 }\n", 4,
                "address outside 0..65535");
  ExpectRefused(in + "velocity = { unit = 0, table = \"input\", address = 0 }\n", 4,
                "outside 1..247");
  ExpectRefused(in + "velocity = { unit = 248, table = \"input\", address = 0 }\n", 4,
                "outside 1..247");
  ExpectRefused(kHead +
                    "align32 = true\n[modbus.inputs]\n"
                    "velocity = { unit = 1, table = \"input\", address = 3, type = \"float32\" }\n",
                5, "odd address 3");
  ExpectRefused(
      kHead +
          "write_function = 6\n[modbus.outputs]\n"
          "command = { unit = 1, table = \"holding\", address = 0, type = \"float32\" }\n",
      5, "write_function 6");
  ExpectRefused(kHead + "write_function = 5\n", 3, "expected 16");
  ExpectRefused(kHead + "max_read = 126\n", 3, "outside 1..125");
  ExpectRefused(kHead + "max_read = 0\n", 3, "outside 1..125");
  ExpectRefused(kHead + "word_order = \"little\"\n", 3, "swapped");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\", address = 0, word_order = "
                     "\"swapped\" }\n",
                4, "word_order is for 32-bit values");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\", address = 0, type = \"float32\", "
                     "word_order = \"cdab\" }\n",
                4, "expected \"big\"");
  ExpectRefused(out + "command = { unit = 1, table = \"input\", address = 0 }\n", 4,
                "writable table");
  ExpectRefused(
      in + "fault_line = { unit = 1, table = \"coil\", address = 0, type = \"uint16\" }\n", 4,
      "no type");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\", address = 0, scale = 0.0 }\n", 4,
                "non-zero");
  ExpectRefused(in + "velocity = { unit = 1, table = \"input\" }\n", 4,
                "needs unit, table and address");
  ExpectRefused(in + "velocity = 3\n", 4, "expected {");
  ExpectRefused(kHead + "[command]\nmin = 2\nmax = 1\n", 3, "");
  // A [command] range the command register cannot hold (an int16 of mV: +-32.767 V) is
  // refused; a 4..20 range is fine (0 V clamps to 4, its off); a curve giving 24 V at 0 V is
  // refused (the safe state would drive the coil).
  const std::string cmd =
      kHead +
      "[modbus.outputs]\ncommand = { unit = 2, table = \"holding\", address = 0, "
      "type = \"int16\", scale = 0.001 }\n";  // command at line 4
  ExpectRefused(cmd + "[command]\nmin = 0.0\nmax = 40.0\n", 7,
                "command.max 40 V is beyond what the command register (/tmp/t.toml:4) can carry "
                "([-32.768, 32.767] V)");
  ExpectRefused(cmd + "[command]\nmin = -40.0\nmax = 20.0\n", 6, "command.min -40 V");
  {
    ModbusProfile p;
    std::string error;
    EXPECT_TRUE(Parse(cmd + "[command]\nmin = 4.0\nmax = 20.0\n", &p, &error)) << error;
  }
  const std::string falling = "/tmp/mrd-falling-" + std::to_string(getpid()) + ".csv";
  std::ofstream(falling) << "E,V\n0,24\n2.25,0\n";
  ExpectRefused(kHead +
                    "[modbus.outputs]\ncommand = { unit = 2, table = \"holding\", address = "
                    "0, type = \"float32\" }\n[command]\ncalibration = \"" +
                    falling + "\"\nmin = 0.0\nmax = 24.0\n",
                5, "the safe state (E = 0 V; also the shutdown's last command) gives 24 V");
  unlink(falling.c_str());
  ExpectRefused(kHead + "[command]\ncalibration = \"/nonexistent.csv\"\n", 4, "calibration");
  ExpectRefused(kHead + "x = [\n", 3, "");  // TOML syntax: toml++'s own reason and line
}

TEST(ModbusProfile, NonMonotonicCalibrationRefused) {
  const std::string csv = "/tmp/mrd-modbus-profile-test-cal.csv";
  FILE* f = std::fopen(csv.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("E,A\n0,0\n1,1\n2,0.5\n", f);
  std::fclose(f);
  ExpectRefused(kHead + "[command]\ncalibration = \"" + csv + "\"\n", 4, "monoton");
  std::remove(csv.c_str());
}

TEST(ModbusProfile, IsModbusProfileFileTellsTheKinds) {
  EXPECT_TRUE(IsModbusProfileFile(kSource + "/firmware/profiles/modbus-float32.toml"));
  EXPECT_FALSE(IsModbusProfileFile(kSource + "/firmware/profiles/mrd-native.toml"));
  EXPECT_FALSE(IsModbusProfileFile("/nonexistent.toml"));
}

// Start-up and periodic writes: read in file order with their values and periods; a bad
// entry is refused at its line with the reason.
TEST(ModbusProfile, StartUpAndPeriodicWrites) {
  const std::string out = kHead +
                          "[modbus.outputs]\n"  // line 3
                          "command = { unit = 2, table = \"holding\", address = 0 }\n";
  const std::string text = out +
                           "[[modbus.startup]]\nunit = 2\ntable = \"holding\"\naddress = 100\n"
                           "value = 500\n"
                           "[[modbus.startup]]\nunit = 2\ntable = \"coil\"\naddress = 7\n"
                           "value = 1\n"
                           "[[modbus.periodic]]\nunit = 2\ntable = \"holding\"\naddress = 101\n"
                           "value = 1\nperiod_ms = 100\nwatchdog_ms = 500\n";
  ModbusProfile p;
  std::string error;
  ASSERT_TRUE(Parse(text, &p, &error)) << error;
  ASSERT_EQ(p.startup.size(), 2U);
  EXPECT_EQ(p.startup[0].address, 100);
  EXPECT_EQ(p.startup[0].value, 500);
  EXPECT_EQ(p.startup[0].request().function, 0x06);
  EXPECT_EQ(p.startup[0].line, 5);
  EXPECT_EQ(p.startup[1].table, ModbusTable::kCoil);
  EXPECT_EQ(p.startup[1].request().function, 0x05);
  ASSERT_EQ(p.periodic.size(), 1U);
  EXPECT_EQ(p.periodic[0].period_ms, 100);
  EXPECT_EQ(p.periodic[0].watchdog_ms, 500);
  EXPECT_EQ(p.writes.size(), 1U) << "fixed writes are not part of the cycle's requests";

  const std::string s = out + "[[modbus.startup]]\n";  // the entry from line 5
  const std::string q = out + "[[modbus.periodic]]\nunit = 2\ntable = \"holding\"\n";  // 5-7
  ExpectRefused(s + "unit = 2\ntable = \"input\"\naddress = 1\nvalue = 1\n", 7,
                "writable table (holding, coil)");
  ExpectRefused(s + "unit = 2\ntable = \"holding\"\naddress = 1\nvalue = 70000\n", 9,
                "integer in 0..65535");
  ExpectRefused(s + "unit = 2\ntable = \"coil\"\naddress = 1\nvalue = 2\n", 9, "a coil is 0 or 1");
  ExpectRefused(s + "unit = 2\ntable = \"holding\"\naddress = 1\n", 5,
                "needs unit, table, address and value");
  ExpectRefused(s + "unit = 2\ntable = \"holding\"\naddress = 1\nvalue = 1\nperiod_ms = 5\n", 10,
                "unknown key (unit, table, address, value)");
  ExpectRefused(s + "unit = 2\ntable = \"holding\"\naddress = 0\nvalue = 1\n", 5,
                "register 0 of unit 2 already carries modbus.outputs.command");
  ExpectRefused(kHead + "startup = 3\n", 3, "expected [[modbus.startup]] entries");
  ExpectRefused(q + "address = 9\nvalue = 1\n", 5, "needs period_ms");
  ExpectRefused(q + "address = 9\nvalue = 1\nperiod_ms = 0\n", 10, "integer in 1..60000");
  ExpectRefused(q + "address = 9\nvalue = 1\nperiod_ms = 100\nwatchdog_ms = 100\n", 11,
                "not above period_ms");
}

// The fault reset: an output role (a coil or register bit) and its rate limit.
TEST(ModbusProfile, FaultResetRoleAndRateLimit) {
  ModbusProfile p;
  std::string error;
  const std::string faults =
      "[modbus.inputs]\ndriver_faults = { unit = 2, table = \"input\", address = 4 }\n";
  ASSERT_TRUE(
      Parse(kHead + "fault_reset_ms = 2500\n" + faults +
                "[modbus.outputs]\nfault_reset = { unit = 2, table = \"coil\", address = 1 }\n",
            &p, &error))
      << error;
  // Without driver_faults the firmware never sees a fault to reset: refused at the role's line.
  ExpectRefused(
      kHead + "[modbus.outputs]\nfault_reset = { unit = 2, table = \"coil\", address = 1 }\n", 4,
      "the profile maps no driver_faults input");
  EXPECT_EQ(p.fault_reset_ms, 2500);
  EXPECT_TRUE(p.Out(ModbusOut::kFaultReset).mapped);
  ASSERT_TRUE(Parse(kHead, &p, &error)) << error;
  EXPECT_EQ(p.fault_reset_ms, 1000);  // the default: at most one reset a second
  ExpectRefused(kHead + "fault_reset_ms = 50\n", 3, "100..600000");
  ExpectRefused(kHead + "fault_reset_ms = \"1s\"\n", 3, "100..600000");
}

}  // namespace
}  // namespace mrd::profile
