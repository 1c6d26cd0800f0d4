// [can] profile in the firmware configuration: loaded relative to the configuration file and
// checked against the routing (every routed input and output, and the grant in lockstep, must
// be a role the profile maps); errors name the configuration's line and the profile's own
// file:line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <string>

#include "mrd/firmware/platform/config.hpp"
#include "mrd/profile/can_profile.hpp"

namespace mrd::firmware {
namespace {

const std::string kProfiles = std::string(MRD_SOURCE_DIR) + "/tests/data/profiles";

bool Parse(const std::string& can, platform::FirmwareConfig* c, std::string* error,
           const std::string& loop = "") {
  const std::string text = "[loop]\n" + loop +
                           "[control]\nlaw = \"force\"\n[can]\nlocal_bus = "
                           "\"/tmp/x.sock\"\n" +
                           can;
  return platform::ParseConfig(text, kProfiles + "/fw.toml", c, error);
}

TEST(ProfileConfigTest, AProfileRelativeToTheConfigurationIsLoaded) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(
      Parse("profile = \"test-driver.toml\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"command\", \"enable\", \"heartbeat\"]\n",
            &c, &error, "clock = \"grant\"\n"))
      << error;
  ASSERT_NE(c.io.can.can_profile, nullptr);
  EXPECT_EQ(c.io.can.can_profile->name, "test-driver");
}

TEST(ProfileConfigTest, RoutingMustMatchTheProfile) {
  platform::FirmwareConfig c;
  std::string error;
  // test-driver has no body velocity and no firmware status message.
  EXPECT_FALSE(
      Parse("profile = \"test-driver.toml\"\ninputs = [\"velocity\", \"demand\", "
            "\"body_velocity\"]\noutputs = [\"command\"]\n",
            &c, &error));
  EXPECT_NE(error.find("fw.toml:"), std::string::npos) << error;
  EXPECT_NE(error.find("maps no signal to input 'body_velocity'"), std::string::npos) << error;
  EXPECT_FALSE(
      Parse("profile = \"test-driver.toml\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"command\", \"status\"]\n",
            &c, &error));
  EXPECT_NE(error.find("maps no signal to output 'status'"), std::string::npos) << error;
  // The native profile maps every input but fault_line.
  EXPECT_FALSE(
      Parse("inputs = [\"velocity\", \"demand\", \"fault_line\"]\noutputs = [\"command\"]\n", &c,
            &error));
  EXPECT_NE(error.find("profile mrd-native maps no signal to input 'fault_line'"),
            std::string::npos)
      << error;
}

TEST(ProfileConfigTest, AMissingOrBrokenProfileIsNamedWithItsLine) {
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_FALSE(
      Parse("profile = \"nothere.toml\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"command\"]\n",
            &c, &error));
  EXPECT_NE(error.find("device profile: " + kProfiles + "/nothere.toml: cannot open"),
            std::string::npos)
      << error;
  const std::string bad = kProfiles + "/../bad-profile.toml";
  std::ofstream(bad) << "name = \"bad\"\ndbc = \"profiles/test-driver.dbc\"\n[inputs]\n"
                        "velocity = \"RigMotion.Nope\"\n";
  EXPECT_FALSE(
      Parse("profile = \"../bad-profile.toml\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"command\"]\n",
            &c, &error));
  unlink(bad.c_str());
  EXPECT_NE(error.find("bad-profile.toml:4: inputs.velocity: message RigMotion"), std::string::npos)
      << error;
}

TEST(ProfileConfigTest, LockstepNeedsTheProfilesGrant) {
  const std::string dir = ::testing::TempDir();
  std::ifstream in(kProfiles + "/test-driver.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  text.replace(text.find("grant = "), std::string("grant = ").size(), "# grant = ");
  const std::string dbc = "dbc = \"test-driver.dbc\"";
  text.replace(text.find(dbc), dbc.size(), "dbc = \"" + kProfiles + "/test-driver.dbc\"");
  const std::string cal = "calibration = \"test-coil.csv\"";
  text.replace(text.find(cal), cal.size(), "calibration = \"" + kProfiles + "/test-coil.csv\"");
  std::ofstream(dir + "/nogrant.toml") << text;
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_FALSE(Parse("profile = \"" + dir +
                         "/nogrant.toml\"\ninputs = [\"velocity\", \"demand\"]\n"
                         "outputs = [\"command\"]\n",
                     &c, &error, "clock = \"grant\"\n"));
  EXPECT_NE(error.find("needs the profile's 'grant' input"), std::string::npos) << error;
}

}  // namespace
}  // namespace mrd::firmware
