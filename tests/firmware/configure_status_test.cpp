// Controller::Configure names why it refused: one test per reason, each a configuration
// the demo table accepts (kNone) with exactly one setting broken.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "mrd/firmware/controller.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

ConfigureStatus ConfigureWith(const ControllerConfig& config,
                              const CoefficientTable& table = test::DemoDamperTable()) {
  Controller controller;
  return controller.Configure(table, config);
}

// The refusal: the fault, its code and a name that is neither "ok" nor "unknown".
void ExpectFault(const ConfigureStatus& s, ConfigureFault fault, Error code = Error::kOutOfRange) {
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.fault, fault) << ConfigureFaultName(s.fault);
  EXPECT_EQ(s.error, code) << ErrorName(s.error);
  const Error converted = s;  // what callers that test the code alone see
  EXPECT_EQ(converted, code);
  EXPECT_STRNE(ConfigureFaultName(s.fault), "ok");
  EXPECT_STRNE(ConfigureFaultName(s.fault), "unknown");
}

TEST(ConfigureStatusTest, DefaultsConfigure) {
  const ConfigureStatus s = ConfigureWith({});
  EXPECT_TRUE(s.ok());
  EXPECT_EQ(s.fault, ConfigureFault::kNone);
  EXPECT_EQ(s.error, Error::kOk);
  EXPECT_STREQ(ConfigureFaultName(s.fault), "ok");
}

TEST(ConfigureStatusTest, TableThatDoesNotValidate) {
  CoefficientTable t = test::DemoDamperTable();
  t.e_max = t.e_min;  // Validate: e_min >= e_max
  ExpectFault(ConfigureWith({}, t), ConfigureFault::kTable, t.Validate());
}

TEST(ConfigureStatusTest, EMaxAboveTheTable) {
  ControllerConfig c;
  c.e_max = 3.0;
  ExpectFault(ConfigureWith(c), ConfigureFault::kEMax);
}

TEST(ConfigureStatusTest, EnvelopeMarginNegative) {
  ControllerConfig c;
  c.envelope_margin = -0.1;
  ExpectFault(ConfigureWith(c), ConfigureFault::kEnvelope);
}

TEST(ConfigureStatusTest, PlausibilityLimitNegativeOrNaN) {
  ControllerConfig c;
  c.velocity_limit = -1.0;
  ExpectFault(ConfigureWith(c), ConfigureFault::kLimits);
  c = {};
  c.displacement_limit = std::nan("");
  ExpectFault(ConfigureWith(c), ConfigureFault::kLimits);
}

TEST(ConfigureStatusTest, SafeVoltageOutsideTheTable) {
  ControllerConfig c;
  c.safe_voltage = 2.5;
  ExpectFault(ConfigureWith(c), ConfigureFault::kSafeVoltage);
  c.safe_voltage = std::numeric_limits<double>::infinity();
  ExpectFault(ConfigureWith(c), ConfigureFault::kSafeVoltage);
}

TEST(ConfigureStatusTest, LawSettingOutOfRange) {
  ControllerConfig c;
  c.law.mode = ControlMode::kConstantVoltage;
  c.law.constant_voltage = 2.0;
  c.e_max = 1.5;  // the constant voltage above E_max
  ExpectFault(ConfigureWith(c), ConfigureFault::kLaw);
  c = {};
  c.law.skyhook_gain = -1.0;
  ExpectFault(ConfigureWith(c), ConfigureFault::kLaw);
}

TEST(ConfigureStatusTest, ClippedOptimalWithoutGains) {
  ControllerConfig c;
  c.law.mode = ControlMode::kClippedOptimal;
  ExpectFault(ConfigureWith(c), ConfigureFault::kClippedGains);
}

TEST(ConfigureStatusTest, WatchdogSettings) {
  ControllerConfig c;
  c.watchdog.max_age_ns = 0;
  ExpectFault(ConfigureWith(c), ConfigureFault::kWatchdog);
  c = {};
  c.watchdog.recover_periods = 0;
  ExpectFault(ConfigureWith(c), ConfigureFault::kWatchdog);
}

TEST(ConfigureStatusTest, CutoffNotAPositiveFrequency) {
  ControllerConfig c;
  c.cutoff_hz = 0.0;
  ExpectFault(ConfigureWith(c), ConfigureFault::kCutoff);
  c.cutoff_hz = std::nan("");
  ExpectFault(ConfigureWith(c), ConfigureFault::kCutoff);
}

TEST(ConfigureStatusTest, EveryFaultHasItsOwnName) {
  const ConfigureFault all[] = {ConfigureFault::kNone,     ConfigureFault::kTable,
                                ConfigureFault::kEMax,     ConfigureFault::kEnvelope,
                                ConfigureFault::kLimits,   ConfigureFault::kSafeVoltage,
                                ConfigureFault::kLaw,      ConfigureFault::kClippedGains,
                                ConfigureFault::kWatchdog, ConfigureFault::kCutoff};
  for (const ConfigureFault a : all) {
    for (const ConfigureFault b : all) {
      if (a != b) {
        EXPECT_STRNE(ConfigureFaultName(a), ConfigureFaultName(b));
      }
    }
  }
  EXPECT_STREQ(ConfigureFaultName(static_cast<ConfigureFault>(200)), "unknown");
}

// A refusal does not replace the configuration of a configured controller.
TEST(ConfigureStatusTest, RefusalKeepsTheRunningConfiguration) {
  Controller controller;
  ASSERT_TRUE(controller.Configure(test::DemoDamperTable(), {}).ok());
  ControllerConfig bad;
  bad.cutoff_hz = -1.0;
  EXPECT_EQ(controller.Configure(test::DemoDamperTable(), bad).fault, ConfigureFault::kCutoff);
  EXPECT_EQ(controller.config().cutoff_hz, ControllerConfig{}.cutoff_hz);
}

}  // namespace
}  // namespace mrd::firmware
