// The [canopen] section of a CAN device profile (canopen_profile.hpp) and the CiA 301 frame
// payloads (canopen_codec.hpp): the shipped canopen-drive profile loads, every refusal names
// file, line and reason, SDO download requests, answers and aborts encode and decode as CiA 301
// lays them out, and abort codes read as the standard's words.
#include "mrd/profile/canopen_profile.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/canopen_codec.hpp"

namespace mrd::profile {
namespace {

const std::string kSource = MRD_SOURCE_DIR;

// A drive (node 5) and a sensor node: RPDO1 0x205, TPDO1 0x185, sensor TPDO1 0x190.
constexpr const char* kDbc = R"(VERSION ""
BO_ 517 Rpdo: 3 Ctrl
 SG_ Current : 0|16@1+ (1,0) [0|2000] "mA" Drive
 SG_ Enable : 16|1@1+ (1,0) [0|1] "" Drive
BO_ 389 Tpdo: 4 Drive
 SG_ Fault : 3|1@1+ (1,0) [0|1] "" Ctrl
BO_ 400 Sensor: 2 Sensors
 SG_ Speed : 0|16@1- (0.01,0) [-300|300] "cm/s" Ctrl
BO_ 1797 Clash: 1 Drive
 SG_ Byte : 0|8@1+ (1,0) [0|255] "" Ctrl
)";

constexpr const char* kHead = R"(name = "co"
dbc = "co.dbc"
[inputs]
velocity = "Sensor.Speed"
driver_faults = "Tpdo.Fault"
[outputs]
command = "Rpdo.Current"
enable = "Rpdo.Enable"
)";

bool Parse(const std::string& canopen, CanProfile* p, std::string* error) {
  const std::string dbc = kDbc;
  return ParseCanProfile(std::string(kHead) + canopen, "co.toml", &dbc, p, error);
}

void ExpectRefused(const std::string& canopen, int line, const std::string& why) {
  CanProfile p;
  std::string error;
  EXPECT_FALSE(Parse(canopen, &p, &error)) << canopen;
  const std::string at = "co.toml:" + std::to_string(line) + ": ";
  EXPECT_EQ(error.rfind(at, 0), 0U) << "expected " << at << why << "\n got " << error;
  EXPECT_NE(error.find(why), std::string::npos) << "expected " << why << "\n got " << error;
}

TEST(CanopenProfileTest, ReadsTheSectionWithDefaults) {
  CanProfile p;
  std::string error;
  ASSERT_TRUE(Parse("[canopen]\nnode_id = 5\nown_node_id = 1\n", &p, &error)) << error;
  ASSERT_TRUE(p.canopen.has_value());
  EXPECT_EQ(p.canopen->node_id, 5);
  EXPECT_EQ(p.canopen->own_node_id, 1);
  EXPECT_EQ(p.canopen->heartbeat_ns, 10'000'000);
  EXPECT_EQ(p.canopen->drive_heartbeat_timeout_ns, 100'000'000);
  EXPECT_TRUE(p.canopen->nmt_start);
  EXPECT_EQ(p.canopen->sync_period_ns, 0);
  EXPECT_EQ(p.canopen->sdo_timeout_ns, 100'000'000);
  EXPECT_TRUE(p.canopen->sdo.empty());
  // Without the section: a plain CAN driver.
  CanProfile plain;
  ASSERT_TRUE(Parse("", &plain, &error)) << error;
  EXPECT_FALSE(plain.canopen.has_value());
}

TEST(CanopenProfileTest, ReadsSdoEntriesInOrder) {
  CanProfile p;
  std::string error;
  ASSERT_TRUE(Parse(R"([canopen]
node_id = 5
own_node_id = 1
heartbeat_ms = 0
drive_heartbeat_timeout_ms = 50
nmt_start = false
sync_period_ms = 2
sdo_timeout_ms = 30
[[canopen.sdo]]
name = "mode"
index = 0x6060
size = 1
value = -3
[[canopen.sdo]]
name = "consumer"
index = 0x1016
subindex = 1
size = 4
value = 0xFFFFFFFF
)",
                    &p, &error))
      << error;
  const CanopenConfig& c = *p.canopen;
  EXPECT_EQ(c.heartbeat_ns, 0);
  EXPECT_EQ(c.drive_heartbeat_timeout_ns, 50'000'000);
  EXPECT_FALSE(c.nmt_start);
  EXPECT_EQ(c.sync_period_ns, 2'000'000);
  EXPECT_EQ(c.sdo_timeout_ns, 30'000'000);
  ASSERT_EQ(c.sdo.size(), 2U);
  EXPECT_EQ(c.sdo[0].name, "mode");
  EXPECT_EQ(c.sdo[0].index, 0x6060);
  EXPECT_EQ(c.sdo[0].subindex, 0);
  EXPECT_EQ(c.sdo[0].size, 1);
  EXPECT_EQ(c.sdo[0].value, -3);
  EXPECT_EQ(c.sdo[0].line, 17);
  EXPECT_EQ(c.sdo[1].subindex, 1);
  EXPECT_EQ(c.sdo[1].value, 0xFFFFFFFFLL);
  EXPECT_EQ(DescribeSdo(c.sdo[0]), "'mode' 0x6060:00 = -3");
}

TEST(CanopenProfileTest, RefusesBadSectionsWithFileLineAndReason) {
  const std::string ids = "[canopen]\nnode_id = 5\nown_node_id = 1\n";  // lines 9..11
  ExpectRefused("[canopen]\nnode_id = 0\nown_node_id = 1\n", 10, "1..127");
  ExpectRefused("[canopen]\nnode_id = 128\nown_node_id = 1\n", 10, "1..127");
  ExpectRefused("[canopen]\nnode_id = 5\nown_node_id = 200\n", 11, "1..127");
  ExpectRefused("[canopen]\nnode_id = 5\nown_node_id = 5\n", 11, "equals node_id 5");
  ExpectRefused("[canopen]\nown_node_id = 1\n", 9, "node_id: missing");
  ExpectRefused("[canopen]\nnode_id = 5\n", 9, "own_node_id: missing");
  ExpectRefused(ids + "heartbeat_ms = 70000\n", 12, "0..65535");
  ExpectRefused(ids + "heartbeat_ms = 1.5\n", 12, "expected an integer");
  ExpectRefused(ids + "nmt_start = 1\n", 12, "true or false");
  ExpectRefused(ids + "sdo_timeout_ms = 0\n", 12, "1..60000");
  ExpectRefused(ids + "bitrate = 500\n", 12, "canopen.bitrate: unknown key");
  {
    CanProfile p;
    std::string error;
    const std::string dbc = kDbc;
    EXPECT_FALSE(ParseCanProfile("name = \"co\"\ndbc = \"co.dbc\"\ncanopen = 3\n", "co.toml", &dbc,
                                 &p, &error));
    EXPECT_EQ(error, "co.toml:3: canopen: expected a table");
  }
  const std::string sdo = ids + "[[canopen.sdo]]\nname = \"mode\"\nindex = 0x6060\n";  // 12..14
  ExpectRefused(sdo + "size = 3\nvalue = 1\n", 15, "expected 1, 2 or 4");
  ExpectRefused(sdo + "size = 8\nvalue = 1\n", 15, "expected 1, 2 or 4");
  ExpectRefused(sdo + "size = 1\nvalue = 256\n", 16, "does not fit 1 byte(s) (-128..255)");
  ExpectRefused(sdo + "size = 1\nvalue = -129\n", 16, "does not fit");
  ExpectRefused(sdo + "size = 2\nvalue = 65536\n", 16, "does not fit 2 byte(s)");
  ExpectRefused(sdo + "size = 4\nvalue = 0x100000000\n", 16, "does not fit 4 byte(s)");
  ExpectRefused(sdo + "value = 1.5\n", 15, "expected an integer");
  ExpectRefused(sdo + "value = 1\nunit = \"mA\"\n", 16, "canopen.sdo.unit: unknown key");
  ExpectRefused(sdo + "subindex = 256\nvalue = 1\n", 15, "0..255");
  ExpectRefused(sdo, 12, "missing 'value'");
  ExpectRefused(ids + "[[canopen.sdo]]\nindex = 0x6060\nvalue = 1\n", 12, "missing 'name'");
  ExpectRefused(ids + "[[canopen.sdo]]\nname = \"a\"\nvalue = 1\n", 12, "missing 'index'");
  ExpectRefused(ids + "[[canopen.sdo]]\nname = \"a\"\nindex = 0x0FFF\nvalue = 1\n", 14,
                "4096..65535");
  ExpectRefused(sdo + "value = 1\n[[canopen.sdo]]\nname = \"mode\"\nindex = 0x6061\nvalue = 1\n",
                16, "'mode': duplicate name");
  ExpectRefused(sdo + "value = 1\n[[canopen.sdo]]\nname = \"again\"\nindex = 0x6060\nvalue = 2\n",
                16, "duplicate object 0x6060:00");
}

// A message the profile uses on a COB-ID of the drive (node 5) or the firmware (node 1):
// refused at the DBC's line; the same message without a role is read over.
TEST(CanopenProfileTest, RefusesAProfileMessageOnACanopenCobId) {
  const auto parse = [](unsigned id, bool role, std::string* e) {
    std::string dbc = kDbc;
    dbc.replace(dbc.find("1797"), 4, std::to_string(id));
    std::string head = kHead;
    if (role) head.replace(head.find("[outputs]"), 0, "force = \"Clash.Byte\"\n");
    CanProfile q;
    return ParseCanProfile(head + "[canopen]\nnode_id = 5\nown_node_id = 1\n", "co.toml", &dbc, &q,
                           e);
  };
  const std::pair<unsigned, const char*> clashes[] = {
      {0x000, "the NMT COB-ID"},
      {0x080, "the SYNC COB-ID"},
      {0x085, "the EMCY COB-ID of node 5 ([canopen] node_id)"},
      {0x585, "the SDO response COB-ID of node 5"},
      {0x605, "the SDO request COB-ID of node 5"},
      {0x705, "the heartbeat COB-ID of node 5 ([canopen] node_id)"},
      {0x701, "the heartbeat COB-ID of node 1 ([canopen] own_node_id)"},
  };
  for (const auto& [id, why] : clashes) {
    std::string e;
    EXPECT_FALSE(parse(id, true, &e)) << id;
    char head[64];
    std::snprintf(head, sizeof head, "co.dbc:9: message Clash (0x%03X) collides with ", id);
    EXPECT_EQ(e.rfind(head, 0), 0U) << e;
    EXPECT_NE(e.find(why), std::string::npos) << e;
    EXPECT_TRUE(parse(id, false, &e)) << e;  // no role: not the firmware's business
  }
  std::string e;
  EXPECT_TRUE(parse(0x702, true, &e)) << e;  // another node's heartbeat: free
}

TEST(CanopenProfileTest, TheShippedCanopenDriveProfileLoads) {
  CanProfile p;
  std::string error;
  ASSERT_TRUE(LoadCanProfile(kSource + "/firmware/profiles/canopen-drive.toml", &p, &error))
      << error;
  EXPECT_EQ(p.name, "canopen-drive");
  ASSERT_TRUE(p.canopen.has_value());
  EXPECT_EQ(p.canopen->node_id, 5);
  EXPECT_EQ(p.canopen->own_node_id, 1);
  EXPECT_EQ(p.canopen->drive_heartbeat_timeout_ns, 50'000'000);
  ASSERT_EQ(p.canopen->sdo.size(), 3U);
  EXPECT_EQ(p.canopen->sdo[0].index, 0x6060);
  EXPECT_EQ(p.canopen->sdo[0].value, -3);
  EXPECT_EQ(p.command_unit, "mA");
  // The drive's PDOs: RPDO1 0x200 + 5 carries the set-point, TPDO1 0x180 + 5 the fault bit.
  const auto id = [&](SignalRef r) {
    return p.dbc.messages[static_cast<std::size_t>(r.message)].id;
  };
  EXPECT_EQ(id(p.outputs[static_cast<std::size_t>(CanOut::kCommand)]), 0x205U);
  EXPECT_EQ(id(p.inputs[static_cast<std::size_t>(CanIn::kDriverFaults)]), 0x185U);
  EXPECT_EQ(id(p.inputs[static_cast<std::size_t>(CanIn::kVelocity)]), 0x190U);
  // 1 V is 200 mA through the coil's curve.
  CommandMap m = p.command;
  EXPECT_NEAR(m.Apply(1.0, 1.0), 200.0, 1e-9);
}

// CiA 301 expedited download: 0x2F / 0x2B / 0x23 for 1 / 2 / 4 bytes, index little-endian.
TEST(CanopenCodecTest, EncodesExpeditedDownloads) {
  std::uint8_t d[8];
  ASSERT_TRUE(canopen::EncodeSdoDownload(0x6060, 0, 1, -3, d));
  EXPECT_EQ(std::vector<int>(d, d + 8), (std::vector<int>{0x2F, 0x60, 0x60, 0x00, 0xFD, 0, 0, 0}));
  ASSERT_TRUE(canopen::EncodeSdoDownload(0x1017, 0, 2, 10, d));
  EXPECT_EQ(std::vector<int>(d, d + 8), (std::vector<int>{0x2B, 0x17, 0x10, 0x00, 0x0A, 0, 0, 0}));
  ASSERT_TRUE(canopen::EncodeSdoDownload(0x1016, 1, 4, 0x00010032, d));
  EXPECT_EQ(std::vector<int>(d, d + 8),
            (std::vector<int>{0x23, 0x16, 0x10, 0x01, 0x32, 0x00, 0x01, 0x00}));
  EXPECT_FALSE(canopen::EncodeSdoDownload(0x1016, 1, 3, 0, d));
  // The server's view of the same request.
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  int size = 0;
  std::uint32_t raw = 0;
  ASSERT_TRUE(canopen::EncodeSdoDownload(0x6060, 0, 1, -3, d));
  ASSERT_TRUE(canopen::DecodeSdoDownloadRequest(d, 8, &index, &sub, &size, &raw));
  EXPECT_EQ(index, 0x6060);
  EXPECT_EQ(sub, 0);
  EXPECT_EQ(size, 1);
  EXPECT_EQ(raw, 0xFDU);
  const std::uint8_t three[8] = {0x27, 0x00, 0x20, 0x02, 1, 2, 3, 4};  // 3 bytes: the 4th ignored
  ASSERT_TRUE(canopen::DecodeSdoDownloadRequest(three, 8, &index, &sub, &size, &raw));
  EXPECT_EQ(size, 3);
  EXPECT_EQ(raw, 0x030201U);
  const std::uint8_t upload[8] = {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0};
  EXPECT_FALSE(canopen::DecodeSdoDownloadRequest(upload, 8, &index, &sub, &size, &raw));
  const std::uint8_t segmented[8] = {0x21, 0x00, 0x10, 0x00, 9, 0, 0, 0};  // e = 0
  EXPECT_FALSE(canopen::DecodeSdoDownloadRequest(segmented, 8, &index, &sub, &size, &raw));
  EXPECT_FALSE(canopen::DecodeSdoDownloadRequest(d, 7, &index, &sub, &size, &raw));
}

TEST(CanopenCodecTest, DecodesAnswersAndAborts) {
  std::uint8_t d[8];
  std::uint32_t code = 0;
  canopen::EncodeSdoDownloadAck(0x6060, 0, d);
  EXPECT_EQ(std::vector<int>(d, d + 8), (std::vector<int>{0x60, 0x60, 0x60, 0, 0, 0, 0, 0}));
  EXPECT_EQ(canopen::DecodeSdoReply(d, 8, 0x6060, 0, &code), canopen::SdoReply::kAck);
  EXPECT_EQ(canopen::DecodeSdoReply(d, 8, 0x6060, 1, &code), canopen::SdoReply::kOther);
  EXPECT_EQ(canopen::DecodeSdoReply(d, 8, 0x6061, 0, &code), canopen::SdoReply::kOther);
  EXPECT_EQ(canopen::DecodeSdoReply(d, 4, 0x6060, 0, &code), canopen::SdoReply::kOther);
  canopen::EncodeSdoAbort(0x6060, 0, 0x06090030, d);
  EXPECT_EQ(std::vector<int>(d, d + 8),
            (std::vector<int>{0x80, 0x60, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06}));
  EXPECT_EQ(canopen::DecodeSdoReply(d, 8, 0x6060, 0, &code), canopen::SdoReply::kAbort);
  EXPECT_EQ(code, 0x06090030U);
  const std::uint8_t upload_reply[8] = {0x4F, 0x60, 0x60, 0x00, 0xFD, 0, 0, 0};
  EXPECT_EQ(canopen::DecodeSdoReply(upload_reply, 8, 0x6060, 0, &code), canopen::SdoReply::kOther);
}

TEST(CanopenCodecTest, AbortCodesReadAsTheStandardsWords) {
  EXPECT_STREQ(canopen::SdoAbortText(0x06090030), "value range of parameter exceeded");
  EXPECT_STREQ(canopen::SdoAbortText(0x06020000), "object does not exist in the object dictionary");
  EXPECT_STREQ(canopen::SdoAbortText(0x06010002), "attempt to write a read only object");
  EXPECT_STREQ(canopen::SdoAbortText(0x08000022),
               "data cannot be transferred or stored to the application because of the present "
               "device state");
  EXPECT_STREQ(canopen::SdoAbortText(0x12345678), "unknown abort code");
  SdoDownload s;
  s.name = "modes of operation: current";
  s.index = 0x6060;
  s.value = -3;
  EXPECT_EQ(SdoRefusalMessage(s, 0x06090030),
            "drive refused SDO 'modes of operation: current' 0x6060:00 = -3: abort 0x06090030 "
            "value range of parameter exceeded");
  EXPECT_STREQ(canopen::NmtStateName(0x05), "operational");
  EXPECT_STREQ(canopen::NmtStateName(0x7F), "pre-operational");
  EXPECT_STREQ(canopen::NmtStateName(0x85), "operational");  // toggle bit masked
  EXPECT_STREQ(canopen::NmtStateName(0x00), "boot-up");
  EXPECT_STREQ(canopen::NmtStateName(0x04), "stopped");
}

}  // namespace
}  // namespace mrd::profile
