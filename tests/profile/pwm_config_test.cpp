// [pwm] in the firmware configuration: the profile it reads (its own key, else the [can]
// section's file), the routing (the command driven by exactly one bus; [pwm] drives only the
// command), and refusals naming the configuration's line and the profile's own file:line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <string>

#include "mrd/firmware/platform/config.hpp"
#include "mrd/profile/pwm_profile.hpp"

namespace mrd::firmware {
namespace {

const std::string kProfiles = std::string(MRD_SOURCE_DIR) + "/firmware/profiles";
const std::string kPwmEnable = kProfiles + "/pwm-enable.toml";

constexpr const char* kHead = "[control]\nlaw = \"force\"\n";
const std::string kCan = "[can]\nlocal_bus = \"/tmp/x.sock\"\nprofile = \"" + kPwmEnable +
                         "\"\ninputs = [\"velocity\", \"demand\"]\noutputs = [\"status\"]\n";
constexpr const char* kGpio =
    "[gpio]\nsim_chip = \"/tmp/x.chip\"\noutputs = [\"enable\", \"heartbeat\"]\n"
    "enable_line = 17\nheartbeat_line = 18\n";

bool Parse(const std::string& body, platform::FirmwareConfig* c, std::string* error) {
  return platform::ParseConfig(std::string(kHead) + body, "/tmp/fw.toml", c, error);
}

TEST(PwmConfigTest, TheCanProfileServesThePwmOutputByDefault) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(Parse(kCan + kGpio +
                        "[pwm]\nsysfs = \"/tmp/pwm-tree\"\nchip = 2\nchannel = 1\n"
                        "outputs = [\"command\"]\n",
                    &c, &error))
      << error;
  EXPECT_TRUE(c.io.pwm.enabled);
  EXPECT_EQ(c.io.pwm.outputs, Bit(Output::kCommand));
  EXPECT_EQ(c.io.pwm.sysfs, "/tmp/pwm-tree");
  EXPECT_EQ(c.io.pwm.chip, 2);
  EXPECT_EQ(c.io.pwm.channel, 1);
  ASSERT_NE(c.io.pwm.pwm_profile, nullptr);
  EXPECT_EQ(c.io.pwm.pwm_profile->name, "pwm-enable");
  EXPECT_EQ(c.io.pwm.pwm_profile->period_ns, 50000);
  EXPECT_EQ(c.io.pwm.period_ns, c.period_ns);
  // The default class directory.
  platform::FirmwareConfig d;
  ASSERT_TRUE(Parse(kCan + "[pwm]\noutputs = [\"command\"]\n", &d, &error)) << error;
  EXPECT_EQ(d.io.pwm.sysfs, "/sys/class/pwm");
  EXPECT_EQ(d.io.pwm.chip, 0);
}

TEST(PwmConfigTest, ItsOwnProfileKeyWinsAndWorksWithoutACanProfile) {
  platform::FirmwareConfig c;
  std::string error;
  // Sensors in the built-in mrd-native frames, the command as a PWM duty.
  ASSERT_TRUE(
      Parse("[can]\nlocal_bus = \"/tmp/x.sock\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"heartbeat\"]\n[pwm]\noutputs = [\"command\"]\nprofile = \"" +
                kPwmEnable + "\"\n",
            &c, &error))
      << error;
  ASSERT_NE(c.io.pwm.pwm_profile, nullptr);
  EXPECT_EQ(c.io.can.can_profile, nullptr);  // mrd-native
}

TEST(PwmConfigTest, RoutingRefusals) {
  platform::FirmwareConfig c;
  std::string error;
  // The command on CAN and on PWM.
  EXPECT_FALSE(
      Parse("[can]\nlocal_bus = \"/tmp/x.sock\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"command\"]\n[pwm]\noutputs = [\"command\"]\nprofile = \"" +
                kPwmEnable + "\"\n",
            &c, &error));
  EXPECT_NE(error.find("/tmp/fw.toml:8: output 'command' is driven by two buses"),
            std::string::npos)
      << error;
  // [pwm] drives the command only, and must drive it.
  EXPECT_FALSE(Parse(kCan + "[pwm]\noutputs = [\"enable\"]\n", &c, &error));
  EXPECT_NE(error.find("/tmp/fw.toml:9: 'outputs' has 'enable'; allowed: command"),
            std::string::npos)
      << error;
  EXPECT_FALSE(Parse(kCan + "[pwm]\noutputs = []\n", &c, &error));
  EXPECT_NE(error.find("[pwm] drives no output"), std::string::npos) << error;
  // Without [pwm] nothing drives the command here.
  EXPECT_FALSE(Parse(kCan, &c, &error));
  EXPECT_NE(error.find("no bus drives the 'command' output"), std::string::npos) << error;
  // Unknown key.
  EXPECT_FALSE(Parse(kCan + "[pwm]\noutputs = [\"command\"]\nfrequency = 20000\n", &c, &error));
  EXPECT_NE(error.find("/tmp/fw.toml:10: unknown key 'frequency' in [pwm]"), std::string::npos)
      << error;
  // A PWM output needs the sensors from somewhere.
  EXPECT_FALSE(
      Parse("[pwm]\noutputs = [\"command\"]\nprofile = \"" + kPwmEnable + "\"\n", &c, &error));
  EXPECT_NE(error.find("no bus serves input 'velocity'"), std::string::npos) << error;
}

TEST(PwmConfigTest, AProfileWithoutAPwmSectionOrNoneAtAllIsRefused) {
  platform::FirmwareConfig c;
  std::string error;
  const std::string can_native =
      "[can]\nlocal_bus = \"/tmp/x.sock\"\ninputs = [\"velocity\", \"demand\"]\n"
      "outputs = [\"heartbeat\"]\n";
  EXPECT_FALSE(Parse(can_native + "[pwm]\noutputs = [\"command\"]\n", &c, &error));
  EXPECT_NE(error.find("/tmp/fw.toml:8: [pwm] needs a device profile with a [pwm] section"),
            std::string::npos)
      << error;
  EXPECT_FALSE(Parse(can_native + "[pwm]\noutputs = [\"command\"]\nprofile = \"" + kProfiles +
                         "/mrd-native.toml\"\n",
                     &c, &error));
  EXPECT_NE(error.find("/tmp/fw.toml:9: device profile: " + kProfiles +
                       "/mrd-native.toml:1: pwm: no [pwm] section"),
            std::string::npos)
      << error;
}

TEST(PwmConfigTest, ABrokenPwmSectionIsNamedByTheProfilesLine) {
  const std::string dir = ::testing::TempDir();
  std::ifstream in(kPwmEnable);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto at = text.find("period_ns = 50000");
  ASSERT_NE(at, std::string::npos);
  int line = 1;
  for (std::size_t i = 0; i < at; ++i) line += text[i] == '\n';
  text.replace(at, std::string("period_ns = 50000").size(), "period_ns = 0");
  const std::string cal = "calibration = \"pwm-enable-coil.csv\"";
  text.replace(text.find(cal), cal.size(),
               "calibration = \"" + kProfiles + "/pwm-enable-coil.csv\"");
  const std::string path = dir + "/broken-pwm.toml";
  std::ofstream(path) << text;
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_FALSE(
      Parse("[can]\nlocal_bus = \"/tmp/x.sock\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"heartbeat\"]\n[pwm]\noutputs = [\"command\"]\nprofile = \"" +
                path + "\"\n",
            &c, &error));
  unlink(path.c_str());
  EXPECT_NE(error.find(path + ":" + std::to_string(line) + ": pwm.period_ns"), std::string::npos)
      << error;
}

}  // namespace
}  // namespace mrd::firmware
