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
  for (const char* bus : {"[gpio]\nsim_chip = \"/tmp/chip\"\noutputs = [\"enable\"]\n",
                          "[pwm]\noutputs = [\"command\"]\n"}) {
    ExpectRefused("[channels]\ncount = 4\n" + std::string(bus), 2,
                  "[gpio] and [pwm] serve one channel only");
  }
  // [can] or [modbus] with several channels needs a device profile per channel.
  ExpectRefused("[channels]\ncount = 2\n[can]\ninterface = \"vcan0\"\n", 2,
                "several channels need one device profile each; give [channels] can_profiles");
  ExpectRefused("[channels]\ncount = 4\n[modbus]\ndevice = \"/dev/ttyUSB0\"\n", 2,
                "count 4 with [modbus]: several channels need one device profile each; give "
                "[channels] modbus_profiles");
  // Both bus sections: one bus for several channels.
  ExpectRefused(
      "[channels]\ncount = 2\n[can]\ninterface = \"vcan0\"\n[modbus]\n"
      "device = \"/dev/ttyUSB0\"\n",
      2, "[can] and [modbus] are both given; several channels share one bus");
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

// The four shipped Modbus corner maps, as a TOML list (absolute paths).
std::string ModbusCorners(int n) {
  std::string list;
  for (const char* c : {"fl", "fr", "rl", "rr"}) {
    if (n-- <= 0) break;
    list += std::string(list.empty() ? "" : ", ") + "\"" + MRD_SOURCE_DIR +
            "/firmware/profiles/modbus-corner-" + c + ".toml\"";
  }
  return "[" + list + "]";
}

constexpr const char* kModbusLink =
    "[modbus]\nmode = \"tcp\"\nhost = \"127.0.0.1\"\nport = 15020\n"
    "inputs = [\"velocity\", \"displacement\", \"demand\"]\n"
    "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";

TEST(ChannelsConfigCliTest, ModbusProfilesOnePerChannelOnTheOneLink) {
  TempDir dir;
  const std::string cfg = dir.File("fw.toml");
  std::ofstream(cfg) << "[loop]\nclock = \"grant\"\n[control]\nlaw = \"force\"\n"
                        "[channels]\ncount = 4\nmodbus_profiles = "
                     << ModbusCorners(4) << "\n"
                     << kModbusLink;
  const CommandResult r = test::Run(Firmware() + " --check-config " + cfg);
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* line : {"modbus channel 0 (modbus-corner-fl): command = 0 V, enable = 0",
                           "modbus channel 3 (modbus-corner-rr): command = 0 V, enable = 0"}) {
    EXPECT_NE(r.output.find(line), std::string::npos) << r.output;
  }
}

TEST(ChannelsConfigCliTest, ModbusProfilesRefusals) {
  const std::string four = "[channels]\ncount = 4\nmodbus_profiles = " + ModbusCorners(4) + "\n";
  // Not one per channel.
  ExpectRefused("[channels]\ncount = 3\nmodbus_profiles = " + ModbusCorners(4) + "\n" + kModbusLink,
                3, "[channels] modbus_profiles names 4 device profiles; count is 3");
  // Both the section's profile and the channels'.
  ExpectRefused(four + kModbusLink + "profile = \"x.toml\"\n", 10,
                "[modbus] profile and [channels] modbus_profiles are both given");
  // No link to share.
  ExpectRefused(four, 3, "modbus_profiles needs a [modbus] section");
  // Both lists: one bus for several channels.
  ExpectRefused(four + "can_profiles = " + CornerProfiles(4) + "\n" + kModbusLink, 3,
                "can_profiles and modbus_profiles are both given");
  // A channel's map that does not load, that lacks a role the routing names, or two maps that
  // cannot share the link (the same set-point block twice).
  ExpectRefused("[channels]\ncount = 2\nmodbus_profiles = [\"" + std::string(MRD_SOURCE_DIR) +
                    "/firmware/profiles/modbus-corner-fl.toml\", \"missing.toml\"]\n" + kModbusLink,
                3, "[channels] modbus_profiles: channel 1 (missing.toml): device profile: ");
  ExpectRefused(
      "[channels]\ncount = 2\nmodbus_profiles = " + ModbusCorners(2) +
          "\n[modbus]\nmode = \"tcp\"\nhost = \"127.0.0.1\"\nport = 15020\n"
          "inputs = [\"velocity\", \"demand\", \"wheel_velocity\"]\noutputs = [\"command\"]\n",
      3,
      "[channels] modbus_profiles: channel 0 (" + std::string(MRD_SOURCE_DIR) +
          "/firmware/profiles/modbus-corner-fl.toml): profile modbus-corner-fl maps no "
          "register to input 'wheel_velocity'");
  const std::string fl =
      "\"" + std::string(MRD_SOURCE_DIR) + "/firmware/profiles/modbus-corner-fl.toml\"";
  ExpectRefused("[channels]\ncount = 2\nmodbus_profiles = [" + fl + ", " + fl + "]\n" + kModbusLink,
                3, "[channels] modbus_profiles: the maps cannot share one link: ");
  // A channel whose safe state is not the driver's off.
  ExpectRefused(four + kModbusLink + "[safety]\nsafe_voltage = 0.5\n", 11,
                "channel 0: the safe state (safe_voltage 0.5 V)");
}

}  // namespace
}  // namespace mrd::test
