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
  ExpectRefused("[channels]\ncount = 2\n[can]\ninterface = \"vcan0\"\n", 2,
                "several channels run on the simulated dampers of --dry-run only");
  ExpectRefused("[channels]\ncount = 2\n[ctl]\nsocket = \"/tmp/x.sock\"\n", 2,
                "serve one channel only");
  ExpectRefused("[channels]\ncount = 4\n[modbus]\ndevice = \"/dev/ttyUSB0\"\n", 2,
                "--dry-run only");
}

}  // namespace
}  // namespace mrd::test
