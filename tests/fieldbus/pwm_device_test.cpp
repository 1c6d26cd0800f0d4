// The PWM field device against a directory tree that follows the sysfs PWM ABI
// (Documentation/ABI/testing/sysfs-class-pwm): export, period, polarity, duty, enable; the
// command through the calibration; the safe duty; failures; no allocation per period.
#include "mrd/firmware/io/pwm_device.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "support/alloc_counter.hpp"

namespace mrd::firmware {
namespace {

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// CHIP with an export file; optionally pwm0 already there.
class FakePwmChip {
 public:
  explicit FakePwmChip(bool exported) {
    char dir[] = "/tmp/mrd-pwmchip-XXXXXX";
    chip_ = mkdtemp(dir);
    std::ofstream(chip_ + "/export") << "";
    std::ofstream(chip_ + "/npwm") << "1\n";
    if (exported) MakeChannel();
  }
  ~FakePwmChip() { (void)!system(("rm -rf " + chip_).c_str()); }
  void MakeChannel() {
    mkdir((chip_ + "/pwm0").c_str(), 0755);
    for (const char* f : {"period", "duty_cycle", "enable", "polarity"}) {
      std::ofstream(chip_ + "/pwm0/" + f) << "0\n";
    }
  }
  std::string chip() const { return chip_; }
  // The attribute's value as the kernel parses it: up to the first newline (a regular file,
  // unlike sysfs, keeps the tail of a longer earlier value after it).
  std::string Attr(const char* name) const {
    const std::string s = Slurp(chip_ + "/pwm0/" + name);
    return s.substr(0, s.find('\n'));
  }

 private:
  std::string chip_;
};

PwmConfig Config(const std::string& chip) {
  PwmConfig c;
  c.enabled = true;
  c.chip = chip;
  c.channel = 0;
  c.period_ns = 40'000;
  std::string error;
  EXPECT_TRUE(c.map.SetRange(0.0, 100.0, 0.0, &error));
  return c;
}

TEST(PwmDeviceTest, SetsUpTheChannelAndWritesTheDutyOfEachCommand) {
  FakePwmChip chip(true);
  PwmConfig cfg = Config(chip.chip());
  cfg.inversed = true;
  PwmDevice pwm(cfg);
  std::string error;
  ASSERT_TRUE(pwm.Configure(&error)) << error;
  ASSERT_TRUE(pwm.Activate(&error)) << error;
  EXPECT_EQ(chip.Attr("period"), "40000");
  EXPECT_EQ(chip.Attr("polarity"), "inversed");
  EXPECT_EQ(chip.Attr("enable"), "1");
  EXPECT_EQ(chip.Attr("duty_cycle"), "0");
  IoError why = IoError::kNone;
  // Identity map: E = 25 -> 25 % of 40 us.
  EXPECT_EQ(pwm.Write({25.0, true, false, 1}, &why), IoStatus::kOk);
  EXPECT_EQ(chip.Attr("duty_cycle"), "10000");
  EXPECT_EQ(pwm.Write({250.0, true, false, 2}, &why), IoStatus::kOk);  // clamped to 100 %
  EXPECT_EQ(chip.Attr("duty_cycle"), "40000");
  EXPECT_EQ(pwm.Write({25.0, true, true, 3}, &why), IoStatus::kOk);  // safe: safe duty 0
  EXPECT_EQ(chip.Attr("duty_cycle"), "0");
  pwm.Deactivate();
  EXPECT_EQ(chip.Attr("enable"), "0");
  EXPECT_EQ(chip.Attr("duty_cycle"), "0");
}

TEST(PwmDeviceTest, ExportsAChannelThatIsNotThereYet) {
  FakePwmChip chip(false);
  // The "kernel": creates pwm0 when the channel number lands in export.
  std::atomic<bool> done{false};
  std::thread kernel([&] {
    while (!done && Slurp(chip.chip() + "/export") != "0\n") {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    if (!done) chip.MakeChannel();
  });
  PwmDevice pwm(Config(chip.chip()));
  std::string error;
  const bool ok = pwm.Configure(&error);
  done = true;
  kernel.join();
  ASSERT_TRUE(ok) << error;
  EXPECT_EQ(chip.Attr("period"), "40000");
}

TEST(PwmDeviceTest, ThroughTheCalibrationWithoutAllocation) {
  FakePwmChip chip(true);
  PwmConfig cfg = Config(chip.chip());
  const std::string cal = chip.chip() + "/cal.csv";
  std::ofstream(cal) << "E,duty\n0,10\n2.25,90\n";
  std::string error;
  ASSERT_TRUE(cfg.map.LoadCalibration(cal, &error)) << error;
  PwmDevice pwm(cfg);
  ASSERT_TRUE(pwm.Configure(&error)) << error;
  ASSERT_TRUE(pwm.Activate(&error)) << error;
  IoError why = IoError::kNone;
  test::AllocationGuard guard;
  for (int k = 0; k < 1000; ++k) {
    (void)pwm.Write({2.25 * (k % 10) / 9.0, true, false, static_cast<std::uint64_t>(k)}, &why);
  }
  EXPECT_EQ(guard.count(), 0U);
  EXPECT_EQ(pwm.Write({1.125, true, false, 1000}, &why), IoStatus::kOk);  // 50 %
  EXPECT_EQ(chip.Attr("duty_cycle"), "20000");
}

TEST(PwmDeviceTest, RefusesWhatIsNotAChipAndFaultsOnAFailedWrite) {
  PwmDevice none(Config("/nonexistent/pwmchip9"));
  std::string error;
  EXPECT_FALSE(none.Configure(&error));
  EXPECT_NE(error.find("not a sysfs PWM chip"), std::string::npos) << error;

  // A channel whose duty attribute cannot be written: refused at start-up with the path;
  // a write on a device that never started is a fault, never a silent success.
  FakePwmChip chip(true);
  (void)!system(("rm -f " + chip.chip() + "/pwm0/duty_cycle").c_str());
  mkdir((chip.chip() + "/pwm0/duty_cycle").c_str(), 0755);
  PwmDevice broken(Config(chip.chip()));
  EXPECT_FALSE(broken.Configure(&error));
  EXPECT_NE(error.find("pwm0/duty_cycle"), std::string::npos) << error;
  IoError why = IoError::kNone;
  EXPECT_EQ(broken.Write({1.0, true, false, 1}, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kSystem);
}

}  // namespace
}  // namespace mrd::firmware
