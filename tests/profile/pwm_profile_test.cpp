// The PWM part of a device profile (pwm_profile.hpp): [pwm] and [command] read, the duty maps
// there and back (the firmware's and the simulated driver's), the CAN reader tolerating
// [pwm], the shipped pwm-enable profile, and every refusal with file, line and reason.
#include "mrd/profile/pwm_profile.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <string>

#include "mrd/profile/can_profile.hpp"

namespace mrd::profile {
namespace {

const std::string kSource = MRD_SOURCE_DIR;

constexpr const char* kGood = R"(name = "pwm-test"
[pwm]
period_ns = 50000
polarity = "inversed"
min_duty = 0.05
max_duty = 0.95
[command]
unit = "A"
min = 0.0
max = 2.0
)";

bool Parse(const std::string& text, PwmProfile* p, std::string* error) {
  return ParsePwmProfile(text, "/tmp/p.toml", p, error);
}

// Replaces the first occurrence of `what` in kGood.
std::string With(const std::string& what, const std::string& by) {
  std::string t = kGood;
  const auto at = t.find(what);
  EXPECT_NE(at, std::string::npos) << what;
  return t.replace(at, what.size(), by);
}

TEST(PwmProfileTest, ReadsThePwmSectionAndTheCommandRange) {
  PwmProfile p;
  std::string error;
  ASSERT_TRUE(Parse(kGood, &p, &error)) << error;
  EXPECT_EQ(p.name, "pwm-test");
  EXPECT_EQ(p.period_ns, 50000);
  EXPECT_TRUE(p.inversed);
  EXPECT_DOUBLE_EQ(p.min_duty, 0.05);
  EXPECT_DOUBLE_EQ(p.max_duty, 0.95);
  EXPECT_EQ(p.command_unit, "A");
  EXPECT_DOUBLE_EQ(p.command.min(), 0.0);
  EXPECT_DOUBLE_EQ(p.command.max(), 2.0);
  // Defaults: normal polarity, 20 kHz, the full duty range.
  ASSERT_TRUE(Parse("[pwm]\n[command]\nmin = 0\nmax = 10\n", &p, &error)) << error;
  EXPECT_EQ(p.period_ns, 50000);
  EXPECT_FALSE(p.inversed);
  EXPECT_DOUBLE_EQ(p.min_duty, 0.0);
  EXPECT_DOUBLE_EQ(p.max_duty, 1.0);
}

TEST(PwmProfileTest, MapsTheSetPointToDutyAndBack) {
  PwmProfile p;
  std::string error;
  ASSERT_TRUE(Parse(kGood, &p, &error)) << error;
  // The range [0, 2] A onto [5 %, 95 %] of 50 us; clamped outside it.
  EXPECT_DOUBLE_EQ(p.SetpointToDuty(0.0), 0.05);
  EXPECT_DOUBLE_EQ(p.SetpointToDuty(1.0), 0.5);
  EXPECT_DOUBLE_EQ(p.SetpointToDuty(2.0), 0.95);
  EXPECT_DOUBLE_EQ(p.SetpointToDuty(-1.0), 0.05);
  EXPECT_DOUBLE_EQ(p.SetpointToDuty(3.0), 0.95);
  EXPECT_DOUBLE_EQ(p.SetpointToDuty(NAN), 0.05);
  EXPECT_EQ(p.DutyNs(0.5), 25000);
  EXPECT_EQ(p.DutyNs(0.123456789), 6173);  // to the nearest ns
  EXPECT_EQ(p.DutyNs(2.0), 50000);
  EXPECT_EQ(p.DutyNs(-1.0), 0);
  // The simulated driver's side: identity calibration here, so E = the set-point [A].
  EXPECT_DOUBLE_EQ(p.DutyToVolts(25000), 1.0);
  EXPECT_DOUBLE_EQ(p.DutyToVolts(0), 0.0);  // below min_duty: held at the range's end
  EXPECT_DOUBLE_EQ(p.DutyToVolts(50000), 2.0);
  // Round trip within one ns of duty: 2 A / (0.9 x 50000 ns) per ns.
  for (double u = 0.0; u <= 2.0; u += 0.0137) {
    EXPECT_NEAR(p.DutyToVolts(p.DutyNs(p.SetpointToDuty(u))), u, 2.0 / 45000.0) << u;
  }
}

TEST(PwmProfileTest, TheShippedPwmEnableProfileLoadsBothWays) {
  const std::string path = kSource + "/firmware/profiles/pwm-enable.toml";
  PwmProfile p;
  std::string error;
  ASSERT_TRUE(LoadPwmProfile(path, &p, &error)) << error;
  EXPECT_EQ(p.period_ns, 50000);
  EXPECT_FALSE(p.inversed);
  EXPECT_DOUBLE_EQ(p.max_duty, 0.95);
  EXPECT_EQ(p.command.points(), 2U);  // the 5-ohm coil: 10 V -> 2 A
  EXPECT_NEAR(p.DutyToVolts(p.DutyNs(p.SetpointToDuty(p.command.Calibrate(1.5)))), 1.5, 1e-3);
  EXPECT_TRUE(ProfileHasPwm(path));
  EXPECT_FALSE(ProfileHasPwm(kSource + "/firmware/profiles/mrd-native.toml"));
  // The CAN reader takes the same file: [pwm] is tolerated, the command role is not on CAN.
  CanProfile c;
  ASSERT_TRUE(LoadCanProfile(path, &c, &error)) << error;
  EXPECT_EQ(c.name, "pwm-enable");
  EXPECT_FALSE(c.outputs[static_cast<std::size_t>(CanOut::kCommand)].mapped());
  EXPECT_TRUE(c.outputs[static_cast<std::size_t>(CanOut::kStatusSafe)].mapped());
  EXPECT_TRUE(c.inputs[static_cast<std::size_t>(CanIn::kGrant)].mapped());
}

struct Refusal {
  std::string text;
  std::string expect;  // in the error, after "/tmp/p.toml:LINE: "
};

TEST(PwmProfileTest, RefusesWithFileLineAndReason) {
  const Refusal cases[] = {
      {"name = \"x\"\n[command]\nmin = 0\nmax = 1\n", "/tmp/p.toml:1: pwm: no [pwm] section"},
      {"pwm = 3\n", "/tmp/p.toml:1: pwm: expected a table"},
      {With("period_ns = 50000", "period_ns = 0"),
       "/tmp/p.toml:3: pwm.period_ns: expected an integer"},
      {With("period_ns = 50000", "period_ns = 999"), "/tmp/p.toml:3: pwm.period_ns"},
      {With("period_ns = 50000", "period_ns = 50000.5"), "/tmp/p.toml:3: pwm.period_ns"},
      {With("period_ns = 50000", "period_ns = 2000000000"), "/tmp/p.toml:3: pwm.period_ns"},
      {With("\"inversed\"", "\"inverted\""),
       "/tmp/p.toml:4: pwm.polarity: expected \"normal\" or \"inversed\""},
      {With("min_duty = 0.05", "min_duty = -0.1"),
       "/tmp/p.toml:5: pwm.min_duty: expected a duty fraction in [0, 1]"},
      {With("max_duty = 0.95", "max_duty = 1.5"),
       "/tmp/p.toml:6: pwm.max_duty: expected a duty fraction"},
      {With("max_duty = 0.95", "max_duty = \"95%\""), "/tmp/p.toml:6: pwm.max_duty"},
      {With("min_duty = 0.05", "min_duty = 0.95"),
       "/tmp/p.toml:2: pwm: min_duty must be below max_duty"},
      {With("max_duty = 0.95", "max_duty = 0.95\nfrequency_hz = 20000"),
       "/tmp/p.toml:7: pwm.frequency_hz: unknown key (period_ns, polarity, min_duty, max_duty)"},
      {With("unit = \"A\"", "unit = \"A\"\ngain = 2"), "/tmp/p.toml:9: command.gain: unknown key"},
      {With("max = 2.0", ""), "/tmp/p.toml:7: command: a [pwm] profile needs min and max"},
      {With("[command]\nunit = \"A\"\nmin = 0.0\nmax = 2.0\n", ""),
       "/tmp/p.toml:1: command: a [pwm] profile needs a [command] table"},
      {With("max = 2.0", "max = -1.0"), "/tmp/p.toml:7: command range: min must be below max"},
      {With("min = 0.0", "calibration = \"/nonexistent/coil.csv\"\nmin = 0.0"),
       "/tmp/p.toml:9: command.calibration: /nonexistent/coil.csv: cannot open"},
      {"[pwm\n", "/tmp/p.toml:1: "},
  };
  for (const Refusal& c : cases) {
    PwmProfile p;
    std::string error;
    EXPECT_FALSE(Parse(c.text, &p, &error)) << c.text;
    EXPECT_EQ(error.rfind(c.expect, 0), 0U) << "error: " << error << "\nexpected: " << c.expect;
  }
}

TEST(PwmProfileTest, ANonMonotonicCalibrationIsNamedByItsOwnLine) {
  char dir[] = "/tmp/mrd-pwmprofile-XXXXXX";
  const std::string d = mkdtemp(dir);
  std::ofstream(d + "/coil.csv") << "E,A\n0,0\n1,0.5\n2,0.4\n";
  std::ofstream(d + "/p.toml") << With("min = 0.0", "calibration = \"coil.csv\"\nmin = 0.0");
  PwmProfile p;
  std::string error;
  EXPECT_FALSE(LoadPwmProfile(d + "/p.toml", &p, &error));
  EXPECT_NE(error.find(d + "/p.toml:9: command.calibration: " + d + "/coil.csv:4: "),
            std::string::npos)
      << error;
  unlink((d + "/coil.csv").c_str());
  unlink((d + "/p.toml").c_str());
  rmdir(d.c_str());
}

}  // namespace
}  // namespace mrd::profile
