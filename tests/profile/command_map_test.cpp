// From the model's E to the driver's set-point (mrd::profile, command_map.hpp): calibration
// curve, range, slew limit, and the refusals of a bad curve with file, line and reason.
#include "mrd/profile/command_map.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <string>

namespace mrd::profile {
namespace {

std::string Csv(const std::string& text) {
  const std::string path = "/tmp/mrd-cal-" + std::to_string(getpid()) + ".csv";
  std::ofstream(path) << text;
  return path;
}

TEST(CommandMapTest, IdentityWithoutACalibration) {
  CommandMap m;
  EXPECT_DOUBLE_EQ(m.Apply(1.25, 1e-3), 1.25);
  EXPECT_EQ(m.Apply(std::nan(""), 1e-3), 0.0);
}

TEST(CommandMapTest, PiecewiseLinearCalibrationHeldAtItsEnds) {
  CommandMap m;
  std::string error;
  const std::string path = Csv("E,I\n0,0\n1,0.5\n2.25,2.0\n");
  ASSERT_TRUE(m.LoadCalibration(path, &error)) << error;
  unlink(path.c_str());
  EXPECT_EQ(m.points(), 3U);
  EXPECT_DOUBLE_EQ(m.Calibrate(0.5), 0.25);
  EXPECT_DOUBLE_EQ(m.Calibrate(1.625), 1.25);
  EXPECT_DOUBLE_EQ(m.Calibrate(-1.0), 0.0);
  EXPECT_DOUBLE_EQ(m.Calibrate(5.0), 2.0);
  // A decreasing curve (e.g. an inverted PWM input) is monotonic too.
  CommandMap d;
  const std::string dec = Csv("E,duty\n0,90\n2.25,10\n");
  ASSERT_TRUE(d.LoadCalibration(dec, &error)) << error;
  unlink(dec.c_str());
  EXPECT_DOUBLE_EQ(d.Calibrate(1.125), 50.0);
}

TEST(CommandMapTest, RangeClampAndSlewLimit) {
  CommandMap m;
  std::string error;
  ASSERT_TRUE(m.SetRange(0.0, 2.0, 100.0, &error)) << error;  // 100 units/s: 0.1 per ms
  EXPECT_DOUBLE_EQ(m.Apply(0.0, 1e-3), 0.0);
  EXPECT_NEAR(m.Apply(2.0, 1e-3), 0.1, 1e-12);
  EXPECT_NEAR(m.Apply(2.0, 1e-3), 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(m.Apply(9.0, 1.0), 2.0);   // clamp to max
  EXPECT_DOUBLE_EQ(m.Apply(-3.0, 1.0), 0.0);  // clamp to min (step 100 covers it)
  m.Reset();
  EXPECT_DOUBLE_EQ(m.Apply(1.5, 1e-3), 1.5);  // first after a reset: not limited
  EXPECT_FALSE(m.SetRange(2.0, 1.0, 0.0, &error));
  EXPECT_FALSE(m.SetRange(0.0, 1.0, -1.0, &error));
}

// The driver's off (what the safe state must send) and the set-point the safe state sends.
TEST(CommandMapTest, OffIsTheSetpointNearestZeroThatCommandsReach) {
  std::string error;
  CommandMap identity;
  EXPECT_EQ(identity.Off(), 0.0);
  EXPECT_EQ(identity.SafeSetpoint(0.0), 0.0);
  CommandMap unipolar;
  ASSERT_TRUE(unipolar.SetRange(0.0, 2000.0, 0.0, &error));
  EXPECT_EQ(unipolar.Off(), 0.0);
  CommandMap loop;  // a 4..20 mA input: 4 mA is its off
  ASSERT_TRUE(loop.SetRange(4.0, 20.0, 0.0, &error));
  EXPECT_EQ(loop.Off(), 4.0);
  EXPECT_EQ(loop.SafeSetpoint(0.0), 4.0);
  CommandMap bipolar;
  ASSERT_TRUE(bipolar.SetRange(-2.0, 2.0, 0.0, &error));
  EXPECT_EQ(bipolar.Off(), 0.0);
  CommandMap offset;  // no range: the curve's lowest value from 0 V on
  const std::string rising = Csv("E,mA\n0,100\n10,2000\n");
  ASSERT_TRUE(offset.LoadCalibration(rising, &error)) << error;
  unlink(rising.c_str());
  EXPECT_EQ(offset.Off(), 100.0);
  EXPECT_EQ(offset.SafeSetpoint(0.0), 100.0);
  CommandMap falling;  // the safe state's 0 V would be the most current
  const std::string dec = Csv("E,mA\n0,2000\n10,0\n");
  ASSERT_TRUE(falling.LoadCalibration(dec, &error)) << error;
  unlink(dec.c_str());
  ASSERT_TRUE(falling.SetRange(0.0, 2000.0, 0.0, &error));
  EXPECT_TRUE(falling.decreasing());
  EXPECT_EQ(falling.Off(), 0.0);
  EXPECT_EQ(falling.SafeSetpoint(0.0), 2000.0);
  double lo = 0, hi = 0;
  falling.Reach(2.25, &lo, &hi);
  EXPECT_EQ(lo, 0.0);
  EXPECT_EQ(hi, 2000.0);
}

void ExpectRefused(const std::string& text, const std::string& where, const std::string& why) {
  CommandMap m;
  std::string error;
  const std::string path = Csv(text);
  EXPECT_FALSE(m.LoadCalibration(path, &error)) << text;
  unlink(path.c_str());
  EXPECT_NE(error.find(path + where), std::string::npos) << error;
  EXPECT_NE(error.find(why), std::string::npos) << error;
}

TEST(CommandMapTest, RefusesABadCurveWithFileLineAndReason) {
  ExpectRefused("E,I\n0,0\n0,1\n", ":3: ", "increase strictly");
  ExpectRefused("E,I\n0,0\n1,1\n2,0.5\n", ":4: ", "monotonic");
  ExpectRefused("E,I\n0,0\n1,0\n", ":3: ", "monotonic");
  ExpectRefused("E,I\n0,zero\n", ":2: ", "two finite numbers");
  ExpectRefused("E,I\n0,1,2\n", ":2: ", "two finite numbers");
  ExpectRefused("E,I\n0,inf\n", ":2: ", "two finite numbers");
  ExpectRefused("E I\n0,0\n", ":1: ", "two columns");
  ExpectRefused("E,I\n0,0\n", ": ", "fewer than 2");
}

}  // namespace
}  // namespace mrd::profile
