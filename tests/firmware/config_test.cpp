#include "mrd/firmware/platform/config.hpp"

#include <gtest/gtest.h>

namespace mrd::firmware {
namespace {

TEST(ConfigTest, DefaultsWhenEmpty) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(platform::ParseConfig("", "fw.toml", &c, &error)) << error;
  EXPECT_EQ(c.period_ns, 1'000'000);
  EXPECT_FALSE(c.e_max.has_value());
  EXPECT_EQ(c.controller.law.mode, ControlMode::kForceTracking);
}

TEST(ConfigTest, ReadsEverySection) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(platform::ParseConfig(R"(
[loop]
period_us = 2000
priority = 0
lock_memory = false
[control]
law = "constant"
constant_voltage = 2.25
e_max = 2.0
force_limit = 800
[velocity]
source = "displacement"
cutoff_hz = 30
[safety]
safe_voltage = 0.1
max_age_ms = 10
recover_periods = 5
velocity_limit = 80
displacement_limit = 4.5
[simulation]
amplitude_cm = 0.5
substeps = 50
)",
                                    "fw.toml", &c, &error))
      << error;
  EXPECT_EQ(c.period_ns, 2'000'000);
  EXPECT_EQ(c.priority, 0);
  EXPECT_FALSE(c.lock_memory);
  EXPECT_EQ(c.controller.law.mode, ControlMode::kConstantVoltage);
  EXPECT_EQ(c.controller.law.constant_voltage, 2.25);
  EXPECT_EQ(*c.e_max, 2.0);
  EXPECT_EQ(c.controller.law.force_limit, 800.0);
  EXPECT_EQ(c.controller.velocity_source, VelocitySource::kDisplacement);
  EXPECT_EQ(c.controller.cutoff_hz, 30.0);
  EXPECT_EQ(c.controller.safe_voltage, 0.1);
  EXPECT_EQ(c.controller.watchdog.max_age_ns, 10'000'000);
  EXPECT_EQ(c.controller.watchdog.recover_periods, 5U);
  EXPECT_EQ(c.controller.velocity_limit, 80.0);
  EXPECT_EQ(c.controller.displacement_limit, 4.5);
  EXPECT_EQ(c.simulation.amplitude_cm, 0.5);
  EXPECT_EQ(c.simulation.substeps, 50);
}

TEST(ConfigTest, ErrorsNameSourceLineAndReason) {
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_FALSE(platform::ParseConfig("[control]\nlaw = \"pid\"\n", "fw.toml", &c, &error));
  EXPECT_EQ(error,
            "fw.toml:2: 'law' must be one of force | constant | skyhook-on-off | skyhook | "
            "open-loop | groundhook | groundhook-on-off | hybrid | add | sh-add | clipped-optimal");
  EXPECT_FALSE(platform::ParseConfig("[loop]\nperiod_us = \"fast\"\n", "fw.toml", &c, &error));
  EXPECT_EQ(error, "fw.toml:2: 'period_us' must be a number");
  EXPECT_FALSE(platform::ParseConfig("[nope]\n", "fw.toml", &c, &error));
  EXPECT_EQ(error, "fw.toml:1: unknown section 'nope'");
  EXPECT_FALSE(platform::ParseConfig("[loop\n", "fw.toml", &c, &error));
  EXPECT_EQ(error.rfind("fw.toml:1: ", 0), 0U) << error;
  EXPECT_FALSE(platform::ParseConfig("[safety]\nrecover_periods = 0\n", "fw.toml", &c, &error));
  EXPECT_NE(error.find("must be in [1,"), std::string::npos) << error;
}

}  // namespace
}  // namespace mrd::firmware
