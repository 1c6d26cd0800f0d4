// The [channels] section through mrd-firmware --config FILE --dry-run: what it accepts, and
// every bad value refused with "error: FILE:LINE: reason", exit 2.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "host/test_util.hpp"

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }

constexpr const char* kGeometry =
    "cg_to_front_m = 1.2\ncg_to_rear_m = 1.4\ntrack_front_m = 1.5\ntrack_rear_m = 1.5\n"
    "motion_ratio = 0.7\n";

struct Checked {
  int status;
  std::string output;
};

// A short lockstep dry run on a config file holding text (tables beside it: table.bin, the
// compiled-in one; bad.bin, not a table).
Checked Check(const std::string& text) {
  TempDir dir;
  EXPECT_EQ(test::Run(Firmware() + " --write-table " + dir.File("table.bin")).status, 0);
  std::ofstream(dir.File("bad.bin")) << "not a table";
  const std::string cfg = dir.File("fw.toml");
  std::ofstream(cfg) << text;
  const CommandResult r = test::Run(Firmware() + " --config " + cfg + " --dry-run 0.05 --lockstep");
  return {r.status, r.output};
}

// Refused with exit 2 at "fw.toml:LINE: " and a reason containing `why`.
void ExpectRefused(const std::string& text, int line, const std::string& why) {
  SCOPED_TRACE(text);
  const Checked r = Check(text);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("error: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("fw.toml:" + std::to_string(line) + ": "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(why), std::string::npos) << r.output;
}

TEST(ChannelsConfigCliTest, AcceptsCountPolicyTablesAndModalSkyhook) {
  for (const std::string& text : {
           std::string("[channels]\ncount = 1\n"),
           std::string("[channels]\ncount = 8\nfault_policy = \"channel\"\n"),
           std::string("[channels]\ncount = 2\ntables = [\"table.bin\", \"table.bin\"]\n"),
           "[channels]\ncount = 4\nbody_law = \"modal-skyhook\"\n" + std::string(kGeometry) +
               "heave_n_s_per_m = 12000\n",
       }) {
    const Checked r = Check(text);
    EXPECT_EQ(r.status, 0) << text << r.output;
  }
}

TEST(ChannelsConfigCliTest, RefusesEveryBadValueNamingFileAndLine) {
  ExpectRefused("[channels]\ncount = 0\n", 2, "'count' must be in [1, 8]");
  ExpectRefused("[channels]\ncount = 9\n", 2, "'count' must be in [1, 8]");
  ExpectRefused("[channels]\nfault_policy = \"some\"\n", 2, "'fault_policy'");
  ExpectRefused("[channels]\nbody_law = \"pid\"\n", 2, "'body_law'");
  ExpectRefused("[channels]\ncount = 4\nbody_law = \"modal-skyhook\"\ncg_to_front_m = 1.2\n", 3,
                "needs the body geometry");
  ExpectRefused("[channels]\ncount = 2\nbody_law = \"modal-skyhook\"\n" + std::string(kGeometry), 3,
                "needs count = 4");
  ExpectRefused(
      "[control]\nlaw = \"skyhook\"\n[channels]\ncount = 4\nbody_law = "
      "\"modal-skyhook\"\n" +
          std::string(kGeometry),
      5, "needs [control] law = \"force\"");
  ExpectRefused("[channels]\ntrack_rear_m = 1.5\n", 1, "body_law is \"none\"");
  ExpectRefused("[channels]\nmotion_ratio = 1.5\n", 2, "'motion_ratio' must be in");
  ExpectRefused("[channels]\ncount = 2\ntables = [\"table.bin\", \"bad.bin\"]\n", 3,
                "channel 1's table 'bad.bin'");
  ExpectRefused("[channels]\ncount = 2\ntables = [\"table.bin\", \"missing.bin\"]\n", 3,
                "'missing.bin'");
  ExpectRefused("[channels]\ncount = 3\ntables = [\"table.bin\"]\n", 3,
                "tables names 1 tables; count is 3");
  ExpectRefused("[channels]\ntables = []\n", 2, "'tables' must be a list of 1 to 8");
  ExpectRefused("[channels]\ntables = [\"table.bin\", 3]\n", 2, "must hold file names");
}

TEST(ChannelsConfigCliTest, SeveralChannelsWithABusSectionAreRefused) {
  ExpectRefused("[channels]\ncount = 2\n[ctl]\nsocket = \"/tmp/x.sock\"\n", 2,
                "serve one channel only");
  for (const char* bus : {"[modbus]\ndevice = \"/dev/ttyUSB0\"\n",
                          "[gpio]\nsim_chip = \"/tmp/chip\"\noutputs = [\"enable\"]\n",
                          "[pwm]\noutputs = [\"command\"]\n"}) {
    ExpectRefused("[channels]\ncount = 4\n" + std::string(bus), 2,
                  "[modbus], [gpio] and [pwm] serve one channel only");
  }
  // [can] with several channels needs a device profile per channel.
  ExpectRefused("[channels]\ncount = 2\n[can]\ninterface = \"vcan0\"\n", 2,
                "several channels need one device profile each; give [channels] can_profiles");
}

// The four shipped corner profiles, as a TOML list (absolute paths).
std::string CornerProfiles(int n) {
  std::string list;
  for (const char* c : {"fl", "fr", "rl", "rr"}) {
    if (n-- <= 0) break;
    list += std::string(list.empty() ? "" : ", ") + "\"" + MRD_SOURCE_DIR +
            "/firmware/profiles/canopen-corner-" + c + ".toml\"";
  }
  return "[" + list + "]";
}

constexpr const char* kCanBus =
    "[can]\ninterface = \"vcan0\"\ninputs = [\"velocity\", \"displacement\", \"demand\"]\n"
    "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";

TEST(ChannelsConfigCliTest, CanProfilesOnePerChannelOnTheOneCanBus) {
  TempDir dir;
  const std::string cfg = dir.File("fw.toml");
  std::ofstream(cfg) << "[loop]\nclock = \"grant\"\n[control]\nlaw = \"force\"\n"
                        "[channels]\ncount = 4\ncan_profiles = "
                     << CornerProfiles(4) << "\n"
                     << kCanBus;
  const CommandResult r = test::Run(Firmware() + " --check-config " + cfg);
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* line : {"can channel 0 (canopen-corner-fl): DriveRpdo1FL.TargetCurrent",
                           "can channel 3 (canopen-corner-rr): DriveRpdo1RR.TargetCurrent"}) {
    EXPECT_NE(r.output.find(line), std::string::npos) << r.output;
  }
}

TEST(ChannelsConfigCliTest, CanProfilesRefusals) {
  // Not one per channel.
  ExpectRefused("[channels]\ncount = 3\ncan_profiles = " + CornerProfiles(4) + "\n" + kCanBus, 3,
                "[channels] can_profiles names 4 device profiles; count is 3 (one per channel)");
  // Both the section's profile and the channels'.
  ExpectRefused("[channels]\ncount = 2\ncan_profiles = " + CornerProfiles(2) + "\n" + kCanBus +
                    "profile = \"x.toml\"\n",
                8, "[can] profile and [channels] can_profiles are both given");
  // No bus to share.
  ExpectRefused("[channels]\ncount = 2\ncan_profiles = " + CornerProfiles(2) + "\n", 3,
                "can_profiles needs a [can] section");
  // A channel's profile that does not load, or lacks a role the [can] routing names.
  ExpectRefused("[channels]\ncount = 2\ncan_profiles = [\"" + std::string(MRD_SOURCE_DIR) +
                    "/firmware/profiles/canopen-corner-fl.toml\", \"missing.toml\"]\n" + kCanBus,
                3, "[channels] can_profiles: channel 1 (missing.toml): device profile: ");
  ExpectRefused("[channels]\ncount = 2\ncan_profiles = " + CornerProfiles(2) + "\n" + kCanBus +
                    "[loop]\nclock = \"grant\"\n[safety]\nsafe_voltage = 0.5\n",
                11, "channel 0: the safe state (safe_voltage 0.5 V)");
}

}  // namespace
}  // namespace mrd::test
