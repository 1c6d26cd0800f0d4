// The chassis control laws (groundhook, groundhook-on-off, hybrid, add, sh-add): each decision
// rule against hand-worked cases, the inputs each law needs, their refusal at configuration
// when no bus serves those inputs, and the watchdog on a stale or NaN chassis input.
// Sign convention (control_law.hpp): v = body minus wheel (damper extension > 0), f > 0 for
// v > 0; vb, vw [cm/s], ab [cm/s^2] up positive.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "mrd/firmware/control_law.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

ControlInputs In(double v, double vb, double vw, double ab) {
  ControlInputs in;
  in.v = static_cast<Real>(v);
  in.body_velocity = static_cast<Real>(vb);
  in.wheel_velocity = static_cast<Real>(vw);
  in.body_acceleration = static_cast<Real>(ab);
  return in;
}

ControlLaw Law(ControlMode mode, ControlLawConfig c = {}) {
  c.mode = mode;
  EXPECT_TRUE(c.IsValid(0.0, 2.0));
  ControlLaw law;
  law.Configure(c, 0.0, 2.0);
  return law;
}

TEST(ChassisLawTest, GroundhookDemandsMinusGainTimesWheelVelocityWhenDissipative) {
  ControlLawConfig c;
  c.groundhook_gain = 40.0;
  const ControlLaw law = Law(ControlMode::kGroundhook, c);
  // Wheel moving down (vw < 0) while the damper extends (v > 0): the damper pulls the wheel
  // up, as groundhook wants: f = -40 * -2 = 80 N.
  ControlOutput out = law.Update(In(3.0, 0.0, -2.0, 0.0));
  EXPECT_TRUE(out.is_force);
  EXPECT_FLOAT_EQ(static_cast<float>(out.value), 80.0F);
  // Wheel moving up, damper compressing: f = -40 * 2 = -80 N (compression, dissipative).
  EXPECT_FLOAT_EQ(static_cast<float>(law.Update(In(-3.0, 5.0, 2.0, 0.0)).value), -80.0F);
  // Wheel moving up while the damper extends: would need an active push: 0.
  EXPECT_EQ(law.Update(In(3.0, 0.0, 2.0, 0.0)).value, Real(0));
  EXPECT_EQ(law.Update(In(0.0, 0.0, 2.0, 0.0)).value, Real(0));
  // Body velocity plays no part.
  EXPECT_EQ(law.Update(In(3.0, 99.0, -2.0, 7.0)).value,
            law.Update(In(3.0, -99.0, -2.0, 0.0)).value);
}

TEST(ChassisLawTest, GroundhookForceIsClampedToTheLimit) {
  ControlLawConfig c;
  c.groundhook_gain = 1000.0;
  c.force_limit = 500.0;
  const ControlLaw law = Law(ControlMode::kGroundhook, c);
  EXPECT_EQ(law.Update(In(3.0, 0.0, -2.0, 0.0)).value, Real(500));
  EXPECT_EQ(law.Update(In(-3.0, 0.0, 2.0, 0.0)).value, Real(-500));
}

TEST(ChassisLawTest, GroundhookOnOffSwitchesOnTheSignOfMinusWheelVelocityTimesV) {
  const ControlLaw law = Law(ControlMode::kGroundhookOnOff);
  ControlOutput out = law.Update(In(3.0, 0.0, -1.0, 0.0));
  EXPECT_FALSE(out.is_force);
  EXPECT_EQ(out.value, Real(2));
  EXPECT_EQ(law.Update(In(-3.0, 0.0, 1.0, 0.0)).value, Real(2));
  EXPECT_EQ(law.Update(In(3.0, 0.0, 1.0, 0.0)).value, Real(0));
  EXPECT_EQ(law.Update(In(-3.0, 0.0, -1.0, 0.0)).value, Real(0));
  EXPECT_EQ(law.Update(In(3.0, 0.0, 0.0, 0.0)).value, Real(0));
}

TEST(ChassisLawTest, HybridBlendsTheSkyhookAndGroundhookParts) {
  ControlLawConfig c;
  c.hybrid_gain = 10.0;
  c.hybrid_alpha = 0.25;
  const ControlLaw law = Law(ControlMode::kHybrid, c);
  // Both parts active: vb = 4 (vb v > 0), vw = -8 (-vw v > 0):
  // 10 * (0.25 * 4 + 0.75 * 8) = 70 N.
  ControlOutput out = law.Update(In(1.0, 4.0, -8.0, 0.0));
  EXPECT_TRUE(out.is_force);
  EXPECT_FLOAT_EQ(static_cast<float>(out.value), 70.0F);
  // Only the skyhook part: vw v > 0 kills the groundhook part: 10 * 0.25 * 4 = 10 N.
  EXPECT_FLOAT_EQ(static_cast<float>(law.Update(In(1.0, 4.0, 8.0, 0.0)).value), 10.0F);
  // Only the groundhook part: 10 * 0.75 * 8 = 60 N.
  EXPECT_FLOAT_EQ(static_cast<float>(law.Update(In(1.0, -4.0, -8.0, 0.0)).value), 60.0F);
  // Compression, both active: 10 * (0.25 * -4 + 0.75 * -8) = -70 N.
  EXPECT_FLOAT_EQ(static_cast<float>(law.Update(In(-1.0, -4.0, 8.0, 0.0)).value), -70.0F);
  EXPECT_EQ(law.Update(In(1.0, -4.0, 8.0, 0.0)).value, Real(0));
}

TEST(ChassisLawTest, HybridAtItsEndsIsSkyhookOrGroundhook) {
  for (const double vb : {-5.0, 3.0}) {
    for (const double vw : {-7.0, 2.0}) {
      for (const double v : {-2.0, 1.5}) {
        ControlLawConfig c;
        c.hybrid_gain = c.skyhook_gain = c.groundhook_gain = 30.0;
        c.hybrid_alpha = 1.0;
        const ControlLaw sky_end = Law(ControlMode::kHybrid, c);
        const ControlLaw sky = Law(ControlMode::kSkyhookContinuous, c);
        c.hybrid_alpha = 0.0;
        const ControlLaw gnd_end = Law(ControlMode::kHybrid, c);
        const ControlLaw gnd = Law(ControlMode::kGroundhook, c);
        const ControlInputs in = In(v, vb, vw, 0.0);
        EXPECT_FLOAT_EQ(static_cast<float>(sky_end.Update(in).value),
                        static_cast<float>(sky.Update(in).value));
        EXPECT_FLOAT_EQ(static_cast<float>(gnd_end.Update(in).value),
                        static_cast<float>(gnd.Update(in).value));
      }
    }
  }
}

TEST(ChassisLawTest, AddSwitchesOnTheSignOfBodyAccelerationTimesV) {
  const ControlLaw law = Law(ControlMode::kAdd);
  ControlOutput out = law.Update(In(3.0, -9.0, 0.0, 50.0));
  EXPECT_FALSE(out.is_force);
  EXPECT_EQ(out.value, Real(2));
  EXPECT_EQ(law.Update(In(-3.0, 9.0, 0.0, -50.0)).value, Real(2));
  EXPECT_EQ(law.Update(In(3.0, 9.0, 0.0, -50.0)).value, Real(0));
  EXPECT_EQ(law.Update(In(-3.0, -9.0, 0.0, 50.0)).value, Real(0));
  EXPECT_EQ(law.Update(In(3.0, 9.0, 0.0, 0.0)).value, Real(0));
}

TEST(ChassisLawTest, ShAddIsSkyhookBelowTheCrossoverAndAddAbove) {
  ControlLawConfig c;
  c.sh_add_alpha = 10.0;  // [rad/s]
  const ControlLaw law = Law(ControlMode::kSkyhookAdd, c);
  // |ab| = 50 <= 10 * |vb| = 100: skyhook band: vb v decides, ab's sign does not.
  EXPECT_EQ(law.Update(In(2.0, 10.0, 0.0, -50.0)).value, Real(2));
  EXPECT_EQ(law.Update(In(2.0, -10.0, 0.0, 50.0)).value, Real(0));
  // On the boundary (ab^2 - a^2 vb^2 = 0): skyhook.
  EXPECT_EQ(law.Update(In(2.0, 10.0, 0.0, -100.0)).value, Real(2));
  // |ab| = 150 > 100: ADD band: ab v decides, vb's sign does not.
  EXPECT_EQ(law.Update(In(2.0, -10.0, 0.0, 150.0)).value, Real(2));
  EXPECT_EQ(law.Update(In(2.0, 10.0, 0.0, -150.0)).value, Real(0));
  EXPECT_EQ(law.Update(In(-2.0, 10.0, 0.0, -150.0)).value, Real(2));
  // A larger crossover moves the same sample into the skyhook band.
  c.sh_add_alpha = 20.0;
  const ControlLaw wide = Law(ControlMode::kSkyhookAdd, c);
  EXPECT_EQ(wide.Update(In(2.0, 10.0, 0.0, -150.0)).value, Real(2));
}

TEST(ChassisLawTest, EachLawNamesTheInputsItNeeds) {
  struct Case {
    ControlMode mode;
    const char* name;
    bool body_velocity, wheel_velocity, body_acceleration;
  };
  const Case cases[] = {{ControlMode::kGroundhook, "groundhook", false, true, false},
                        {ControlMode::kGroundhookOnOff, "groundhook-on-off", false, true, false},
                        {ControlMode::kHybrid, "hybrid", true, true, false},
                        {ControlMode::kAdd, "add", false, false, true},
                        {ControlMode::kSkyhookAdd, "sh-add", true, false, true},
                        {ControlMode::kSkyhookContinuous, "skyhook", true, false, false}};
  for (const Case& k : cases) {
    const ControlLaw law = Law(k.mode);
    EXPECT_STREQ(ControlModeName(k.mode), k.name);
    EXPECT_EQ(law.needs_body_velocity(), k.body_velocity) << k.name;
    EXPECT_EQ(law.needs_wheel_velocity(), k.wheel_velocity) << k.name;
    EXPECT_EQ(law.needs_body_acceleration(), k.body_acceleration) << k.name;
    EXPECT_FALSE(law.needs_demand()) << k.name;
  }
}

TEST(ChassisLawTest, InvalidParametersAreRefused) {
  ControlLawConfig c;
  c.mode = ControlMode::kHybrid;
  EXPECT_TRUE(c.IsValid(0.0, 2.0));
  c.hybrid_alpha = 1.5;
  EXPECT_FALSE(c.IsValid(0.0, 2.0));
  c.hybrid_alpha = -0.1;
  EXPECT_FALSE(c.IsValid(0.0, 2.0));
  c = {};
  c.groundhook_gain = -1.0;
  EXPECT_FALSE(c.IsValid(0.0, 2.0));
  c = {};
  c.sh_add_alpha = 0.0;
  EXPECT_FALSE(c.IsValid(0.0, 2.0));
  c = {};
  c.hybrid_gain = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(c.IsValid(0.0, 2.0));
}

// [control] in a configuration file: the keys, their ranges, and the routing refusals.
TEST(ChassisLawConfigTest, KeysParseAndOutOfRangeValuesAreRefused) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(
      platform::ParseConfig("[control]\nlaw = \"hybrid\"\nhybrid_gain = 35\nhybrid_alpha = 0.3\n"
                            "groundhook_gain = 12\nsh_add_alpha = 6.5\n",
                            "fw.toml", &c, &error))
      << error;
  EXPECT_EQ(c.controller.law.mode, ControlMode::kHybrid);
  EXPECT_EQ(c.controller.law.hybrid_gain, 35.0);
  EXPECT_EQ(c.controller.law.hybrid_alpha, 0.3);
  EXPECT_EQ(c.controller.law.groundhook_gain, 12.0);
  EXPECT_EQ(c.controller.law.sh_add_alpha, 6.5);
  for (const char* bad : {"hybrid_alpha = 1.2", "hybrid_alpha = -0.5", "groundhook_gain = -3",
                          "sh_add_alpha = 0", "hybrid_gain = nan"}) {
    platform::FirmwareConfig d;
    EXPECT_FALSE(
        platform::ParseConfig(std::string("[control]\n") + bad + "\n", "fw.toml", &d, &error))
        << bad;
    EXPECT_EQ(error.rfind("fw.toml:2:", 0), 0U) << bad << ": " << error;
  }
}

TEST(ChassisLawConfigTest, LawsWhoseInputsNoBusServesAreRefused) {
  struct Case {
    const char* law;
    const char* inputs;
    const char* message;
  };
  const Case cases[] = {
      {"groundhook", "\"velocity\"", "no bus serves input 'wheel_velocity' (groundhook laws)"},
      {"groundhook-on-off", "\"velocity\"",
       "no bus serves input 'wheel_velocity' (groundhook laws)"},
      {"hybrid", "\"velocity\", \"body_velocity\"",
       "no bus serves input 'wheel_velocity' (law \"hybrid\")"},
      {"hybrid", "\"velocity\", \"wheel_velocity\"",
       "no bus serves input 'body_velocity' (law \"hybrid\")"},
      {"add", "\"velocity\", \"body_velocity\"",
       "no bus serves input 'body_acceleration' (law \"add\")"},
      {"sh-add", "\"velocity\", \"body_acceleration\"",
       "no bus serves input 'body_velocity' (law \"sh-add\")"},
      {"sh-add", "\"velocity\", \"body_velocity\"",
       "no bus serves input 'body_acceleration' (law \"sh-add\")"}};
  for (const Case& k : cases) {
    platform::FirmwareConfig c;
    std::string error;
    EXPECT_FALSE(platform::ParseConfig(std::string("[control]\nlaw = \"") + k.law +
                                           "\"\n[can]\ninputs = [" + k.inputs +
                                           "]\noutputs = [\"command\"]\nlocal_bus = \"/tmp/x\"\n",
                                       "fw.toml", &c, &error))
        << k.law;
    EXPECT_NE(error.find(k.message), std::string::npos) << k.law << ": " << error;
  }
  // All routed: accepted (the built-in mrd-native profile maps both chassis signals).
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_TRUE(
      platform::ParseConfig("[control]\nlaw = \"hybrid\"\n[can]\ninputs = [\"velocity\", "
                            "\"body_velocity\", \"wheel_velocity\", \"body_acceleration\"]\n"
                            "outputs = [\"command\"]\nlocal_bus = \"/tmp/x\"\n",
                            "fw.toml", &c, &error))
      << error;
}

TEST(ChassisLawConfigTest, TheBuiltInModbusMapServesNoChassisSignal) {
  platform::FirmwareConfig c;
  std::string error;
  EXPECT_FALSE(
      platform::ParseConfig("[control]\nlaw = \"add\"\n[modbus]\nmode = \"tcp\"\nhost = \"h\"\n"
                            "inputs = [\"velocity\", \"body_acceleration\"]\n"
                            "outputs = [\"command\"]\n",
                            "fw.toml", &c, &error));
  EXPECT_NE(error.find("input 'body_acceleration' needs a Modbus device profile"),
            std::string::npos)
      << error;
}

TEST(ChassisLawConfigTest, CtlSetSwitchesLawsAndTunesTheirParameters) {
  platform::FirmwareConfig c;
  std::string error, why;
  ASSERT_TRUE(
      platform::ParseConfig("[can]\ninputs = [\"velocity\", \"demand\", \"wheel_velocity\"]\n"
                            "outputs = [\"command\"]\nlocal_bus = \"/tmp/x\"\n",
                            "fw.toml", &c, &error))
      << error;
  EXPECT_TRUE(platform::SetParam(&c, "control.law", "groundhook", &why)) << why;
  EXPECT_TRUE(platform::SetParam(&c, "control.groundhook_gain", "25", &why)) << why;
  EXPECT_EQ(c.controller.law.groundhook_gain, 25.0);
  EXPECT_FALSE(platform::SetParam(&c, "control.hybrid_alpha", "2", &why));
  EXPECT_FALSE(platform::SetParam(&c, "control.law", "add", &why));
  EXPECT_NE(why.find("no bus serves input 'body_acceleration'"), std::string::npos) << why;
  EXPECT_EQ(c.controller.law.mode, ControlMode::kGroundhook);
}

// The controller: a stale or NaN chassis input the law reads puts it in the safe state; an
// input it does not read does not.
TEST(ChassisLawControllerTest, StaleOrNaNRequiredInputsEnterTheSafeState) {
  constexpr std::int64_t kMs = 1'000'000;
  struct Case {
    ControlMode mode;
    Input field;
  };
  const Case cases[] = {{ControlMode::kGroundhook, Input::kWheelVelocity},
                        {ControlMode::kGroundhookOnOff, Input::kWheelVelocity},
                        {ControlMode::kHybrid, Input::kWheelVelocity},
                        {ControlMode::kHybrid, Input::kBodyVelocity},
                        {ControlMode::kAdd, Input::kBodyAcceleration},
                        {ControlMode::kSkyhookAdd, Input::kBodyAcceleration},
                        {ControlMode::kSkyhookAdd, Input::kBodyVelocity}};
  for (const Case& k : cases) {
    SCOPED_TRACE(ControlModeName(k.mode));
    ControllerConfig config;
    config.law.mode = k.mode;
    config.watchdog.max_age_ns = 3 * kMs;
    Controller controller;
    ASSERT_EQ(controller.Configure(test::DemoDamperTable(), config), Error::kOk);
    const auto fresh = [](std::int64_t t) {
      SensorFrame f;
      f[Input::kVelocity] = {3.0, t};
      f[Input::kBodyVelocity] = {4.0, t};
      f[Input::kWheelVelocity] = {-2.0, t};
      f[Input::kBodyAcceleration] = {100.0, t};
      return f;
    };
    std::int64_t t = 10 * kMs;
    EXPECT_FALSE(controller.Update(fresh(t), IoStatus::kOk, false, t, 1e-3).safe);
    t += kMs;
    SensorFrame f = fresh(t);
    f[k.field].stamp_ns = t - 3 * kMs - 1;
    ControllerOutput out = controller.Update(f, IoStatus::kOk, false, t, 1e-3);
    EXPECT_TRUE(out.safe);
    EXPECT_NE(out.causes & Watchdog::Bit(FaultCause::kStaleSensor), 0U);
    t += kMs;
    f = fresh(t);
    f[k.field].value = std::numeric_limits<double>::quiet_NaN();
    out = controller.Update(f, IoStatus::kOk, false, t, 1e-3);
    EXPECT_NE(out.causes & Watchdog::Bit(FaultCause::kNonFinite), 0U);
  }
  // Skyhook reads neither chassis signal.
  ControllerConfig config;
  config.law.mode = ControlMode::kSkyhookOnOff;
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), config), Error::kOk);
  SensorFrame f;
  f[Input::kVelocity] = {3.0, 0};
  f[Input::kBodyVelocity] = {4.0, 0};
  EXPECT_EQ(controller.Update(f, IoStatus::kOk, false, 0, 1e-3).causes, 0U);
}

}  // namespace
}  // namespace mrd::firmware
