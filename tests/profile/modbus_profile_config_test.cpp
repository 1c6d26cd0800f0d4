// [modbus] profile in the firmware configuration: loaded relative to the configuration file
// and checked against the routing (every routed input and output, and the grant in lockstep
// when grants travel on Modbus, must be a role the profile maps); errors name the
// configuration's line and the profile's own file:line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "mrd/firmware/platform/config.hpp"
#include "mrd/profile/modbus_profile.hpp"

namespace mrd::firmware {
namespace {

const std::string kProfiles = std::string(MRD_SOURCE_DIR) + "/firmware/profiles";

bool Parse(const std::string& modbus, platform::FirmwareConfig* c, std::string* error,
           const std::string& loop = "", const std::string& dir = kProfiles) {
  const std::string text =
      "[loop]\n" + loop +
      "[control]\nlaw = \"constant\"\nconstant_voltage = 1.0\n[modbus]\nmode = "
      "\"tcp\"\nport = 1502\n" +
      modbus;
  return platform::ParseConfig(text, dir + "/fw.toml", c, error);
}

const std::string kRouting =
    "inputs = [\"velocity\", \"demand\", \"fault_line\"]\n"
    "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";

TEST(ModbusProfileConfigTest, AProfileRelativeToTheConfigurationIsLoaded) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(
      Parse("profile = \"modbus-float32.toml\"\n" + kRouting, &c, &error, "clock = \"grant\"\n"))
      << error;
  ASSERT_NE(c.io.modbus.modbus_profile, nullptr);
  EXPECT_EQ(c.io.modbus.modbus_profile->name, "modbus-float32");
  EXPECT_TRUE(c.io.modbus.lockstep);
  // Without the key: the built-in map, no profile.
  platform::FirmwareConfig plain;
  ASSERT_TRUE(Parse(kRouting, &plain, &error)) << error;
  EXPECT_EQ(plain.io.modbus.modbus_profile, nullptr);
}

// Each four-corner map is a valid one-channel profile on its own (as --check-config takes it).
TEST(ModbusProfileConfigTest, EachCornerMapIsAOneChannelProfile) {
  for (const char* c : {"fl", "fr", "rl", "rr"}) {
    platform::FirmwareConfig cfg;
    std::string error;
    ASSERT_TRUE(Parse(std::string("profile = \"modbus-corner-") + c + ".toml\"\n" + kRouting, &cfg,
                      &error, "clock = \"grant\"\n"))
        << c << ": " << error;
    ASSERT_NE(cfg.io.modbus.modbus_profile, nullptr);
    EXPECT_EQ(cfg.io.modbus.modbus_profile->name, std::string("modbus-corner-") + c);
  }
}

class TempProfile {
 public:
  explicit TempProfile(const std::string& text) {
    char dir[] = "/tmp/mrd-modbus-profile-XXXXXX";
    dir_ = mkdtemp(dir);
    std::ofstream(dir_ + "/p.toml") << text;
  }
  ~TempProfile() {
    unlink((dir_ + "/p.toml").c_str());
    rmdir(dir_.c_str());
  }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
};

TEST(ModbusProfileConfigTest, RoutingMustMatchTheProfile) {
  // Maps velocity, the command and driver_faults only.
  const TempProfile p(
      "name = \"small\"\n[modbus]\n[modbus.inputs]\n"
      "velocity = { unit = 1, table = \"input\", address = 0, type = \"float32\" }\n"
      "driver_faults = { unit = 2, table = \"input\", address = 0 }\n"
      "[modbus.outputs]\ncommand = { unit = 2, table = \"holding\", address = 0, type = "
      "\"float32\" }\n");
  platform::FirmwareConfig c;
  std::string error;
  // fault_line is served by driver_faults.
  EXPECT_TRUE(
      Parse("profile = \"p.toml\"\ninputs = [\"velocity\", \"fault_line\"]\n"
            "outputs = [\"command\"]\n",
            &c, &error, "", p.dir()))
      << error;
  EXPECT_FALSE(
      Parse("profile = \"p.toml\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"command\"]\n",
            &c, &error, "", p.dir()));
  EXPECT_NE(error.find("fw.toml:"), std::string::npos) << error;
  EXPECT_NE(error.find("maps no register to input 'demand'"), std::string::npos) << error;
  EXPECT_FALSE(
      Parse("profile = \"p.toml\"\ninputs = [\"velocity\"]\n"
            "outputs = [\"command\", \"enable\"]\n",
            &c, &error, "", p.dir()));
  EXPECT_NE(error.find("maps no register to output 'enable'"), std::string::npos) << error;
  EXPECT_FALSE(
      Parse("profile = \"p.toml\"\ninputs = [\"velocity\"]\n"
            "outputs = [\"command\", \"status\"]\n",
            &c, &error, "", p.dir()));
  EXPECT_NE(error.find("maps no register to output 'status'"), std::string::npos) << error;
  // Lockstep with grants on Modbus needs the grant role.
  EXPECT_FALSE(Parse("profile = \"p.toml\"\ninputs = [\"velocity\"]\noutputs = [\"command\"]\n", &c,
                     &error, "clock = \"grant\"\n", p.dir()));
  EXPECT_NE(error.find("needs the profile's 'grant' input"), std::string::npos) << error;
}

TEST(ModbusProfileConfigTest, ABrokenProfileIsNamedWithItsLine) {
  const TempProfile p(
      "name = \"bad\"\n[modbus]\nalign32 = true\n[modbus.inputs]\n"
      "velocity = { unit = 1, table = \"input\", address = 1, type = \"float32\" }\n");
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_FALSE(Parse("profile = \"p.toml\"\ninputs = [\"velocity\"]\noutputs = [\"command\"]\n", &c,
                     &error, "", p.dir()));
  // The configuration's line of the key, then the profile's file:line and reason.
  EXPECT_NE(error.find("fw.toml:"), std::string::npos) << error;
  EXPECT_NE(error.find(p.dir() + "/p.toml:5: modbus.inputs.velocity: 32-bit value at odd address"),
            std::string::npos)
      << error;
  EXPECT_FALSE(Parse("profile = \"nothere.toml\"\n" + kRouting, &c, &error));
  EXPECT_NE(error.find("nothere.toml: cannot open"), std::string::npos) << error;
}

}  // namespace
}  // namespace mrd::firmware
