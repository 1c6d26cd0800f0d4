// A CANopen profile in the firmware configuration ([can] profile): the shipped canopen-drive
// profile satisfies the routing (its CANopen heartbeat is the "heartbeat" output), and an error
// in its [canopen] section is named with the profile's file and line, as --check-config shows.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <string>

#include "mrd/firmware/platform/config.hpp"
#include "mrd/profile/can_profile.hpp"

namespace mrd::firmware {
namespace {

const std::string kShipped = std::string(MRD_SOURCE_DIR) + "/firmware/profiles";

bool Parse(const std::string& profile, platform::FirmwareConfig* c, std::string* error) {
  const std::string text =
      "[loop]\nclock = \"grant\"\n[control]\nlaw = \"force\"\n[can]\nlocal_bus = \"/tmp/x.sock\"\n"
      "profile = \"" +
      profile +
      "\"\ninputs = [\"velocity\", \"displacement\", \"demand\"]\n"
      "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";
  return platform::ParseConfig(text, kShipped + "/fw.toml", c, error);
}

TEST(CanopenConfigTest, TheShippedProfileSatisfiesTheRouting) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(Parse("canopen-drive.toml", &c, &error)) << error;
  ASSERT_NE(c.io.can.can_profile, nullptr);
  ASSERT_TRUE(c.io.can.can_profile->canopen.has_value());
  EXPECT_EQ(c.io.can.can_profile->canopen->node_id, 5);
}

TEST(CanopenConfigTest, ABadCanopenSectionIsNamedWithTheProfilesLine) {
  // The shipped profile with the drive's node id out of range.
  std::ifstream in(kShipped + "/canopen-drive.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto at = text.find("node_id = 5");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 11, "node_id = 200");
  const int line =
      1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
  const auto dbc = text.find("dbc = \"canopen-drive.dbc\"");
  text.replace(dbc, 25, "dbc = \"" + kShipped + "/canopen-drive.dbc\"");
  const auto csv = text.find("calibration = \"canopen-coil.csv\"");
  text.replace(csv, 32, "calibration = \"" + kShipped + "/canopen-coil.csv\"");
  const std::string path = ::testing::TempDir() + "/bad-canopen.toml";
  std::ofstream(path) << text;
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_FALSE(Parse(path, &c, &error));
  EXPECT_NE(error.find(path + ":" + std::to_string(line) +
                       ": canopen.node_id: expected an integer "
                       "in 1..127"),
            std::string::npos)
      << error;
  unlink(path.c_str());
}

}  // namespace
}  // namespace mrd::firmware
