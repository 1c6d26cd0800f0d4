// The PWM field device against a directory tree that follows the sysfs PWM ABI
// (Documentation/ABI/testing/sysfs-class-pwm): export, the order of the set-up writes (duty 0,
// period, polarity while disabled, then duty and enable), duty <= period, the command through
// the profile's map and duty range with its slew limit, the safe duty, failures, and no
// allocation per period through FieldbusIo with the device built from a configuration.
#include "mrd/firmware/io/pwm/pwm_device.hpp"

#include <gtest/gtest.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "mrd/firmware/io/devices.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/profile/pwm_profile.hpp"

// GCC 12 takes the counting operator delete's free() for a mismatch with the counting new
// once a std::string or shared_ptr release is inlined here: a false positive.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include "support/alloc_counter.hpp"
#include "support/io_time.hpp"
#pragma GCC diagnostic pop

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

// Identity calibration, range [0, 100] onto the full duty range: E = 25 -> 25 %.
PwmConfig Config(const std::string& chip) {
  PwmConfig c;
  c.enabled = true;
  c.chip = chip;
  c.channel = 0;
  c.profile.period_ns = 40'000;
  std::string error;
  EXPECT_TRUE(c.profile.command.SetRange(0.0, 100.0, 0.0, &error));
  return c;
}

TEST(PwmDeviceTest, SetsUpTheChannelAndWritesTheDutyOfEachCommand) {
  FakePwmChip chip(true);
  PwmConfig cfg = Config(chip.chip());
  cfg.profile.inversed = true;
  PwmDevice pwm(cfg);
  std::string error;
  ASSERT_TRUE(pwm.Configure(&error)) << error;
  ASSERT_TRUE(pwm.Activate(&error)) << error;
  EXPECT_EQ(chip.Attr("period"), "40000");
  EXPECT_EQ(chip.Attr("polarity"), "inversed");
  EXPECT_EQ(chip.Attr("enable"), "1");
  EXPECT_EQ(chip.Attr("duty_cycle"), "0");
  IoError why = IoError::kNone;
  EXPECT_EQ(pwm.Write(::mrd::test::NowIo(), {25.0, true, false, 1}, &why), IoStatus::kOk);
  EXPECT_EQ(chip.Attr("duty_cycle"), "10000");
  EXPECT_EQ(pwm.Write(::mrd::test::NowIo(), {250.0, true, false, 2}, &why),
            IoStatus::kOk);  // clamped: duty = period
  EXPECT_EQ(chip.Attr("duty_cycle"), "40000");
  EXPECT_EQ(pwm.Write(::mrd::test::NowIo(), {NAN, true, false, 3}, &why),
            IoStatus::kOk);  // non-finite: the low end
  EXPECT_EQ(chip.Attr("duty_cycle"), "0");
  EXPECT_EQ(pwm.Write(::mrd::test::NowIo(), {0.0, false, true, 4}, &why),
            IoStatus::kOk);  // safe: 0 V
  EXPECT_EQ(chip.Attr("duty_cycle"), "0");
  pwm.Deactivate();
  EXPECT_EQ(chip.Attr("enable"), "0");
  EXPECT_EQ(chip.Attr("duty_cycle"), "0");
}

// The channel starts at the safe voltage's duty: 5 V of [0, 100] -> 5 %.
PwmConfig SafeAtFive(const std::string& chip) {
  PwmConfig cfg = Config(chip);
  cfg.safe_volts = 5.0;
  return cfg;
}

// The order of the attribute writes Configure and Activate make, seen through inotify (one
// IN_MODIFY per write, in order).
std::vector<std::string> SetUpWrites(const FakePwmChip& chip, PwmDevice* pwm, std::string* error) {
  const int in = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  EXPECT_GE(in, 0);
  std::vector<std::string> names;
  std::vector<int> wds;
  for (const char* f : {"period", "duty_cycle", "enable", "polarity"}) {
    wds.push_back(inotify_add_watch(in, (chip.chip() + "/pwm0/" + f).c_str(), IN_MODIFY));
    names.emplace_back(f);
  }
  EXPECT_TRUE(pwm->Configure(error)) << *error;
  EXPECT_TRUE(pwm->Activate(error)) << *error;
  std::vector<std::string> order;
  alignas(inotify_event) char buf[4096];
  for (ssize_t n; (n = read(in, buf, sizeof buf)) > 0;) {
    for (char* p = buf; p < buf + n;) {
      const auto* e = reinterpret_cast<const inotify_event*>(p);
      for (std::size_t i = 0; i < wds.size(); ++i) {
        if (wds[i] == e->wd) order.push_back(names[i]);
      }
      p += sizeof(inotify_event) + e->len;
    }
  }
  close(in);
  return order;
}

// The kernel refuses a write that leaves duty > period or period 0, and a polarity change
// while enabled. A channel an earlier user left with a short period and a long duty: disabled,
// duty 0, then the period and polarity; the first real duty after both.
TEST(PwmDeviceTest, ALeftOverChannelIsDisabledAndZeroedBeforeTheNewPeriod) {
  FakePwmChip chip(true);
  std::ofstream(chip.chip() + "/pwm0/period") << "1000\n";
  std::ofstream(chip.chip() + "/pwm0/duty_cycle") << "900\n";
  std::ofstream(chip.chip() + "/pwm0/enable") << "1\n";
  std::string error;
  PwmDevice pwm(SafeAtFive(chip.chip()));
  const std::vector<std::string> want = {"enable",   "duty_cycle", "period",
                                         "polarity", "duty_cycle", "enable"};
  EXPECT_EQ(SetUpWrites(chip, &pwm, &error), want);
  EXPECT_EQ(chip.Attr("period"), "40000");
  EXPECT_EQ(chip.Attr("duty_cycle"), "2000");
  EXPECT_EQ(chip.Attr("enable"), "1");
}

// A freshly exported channel (period 0, disabled): the period comes before any other write.
TEST(PwmDeviceTest, AFreshChannelGetsItsPeriodFirst) {
  FakePwmChip chip(true);  // every attribute 0
  std::string error;
  PwmDevice pwm(SafeAtFive(chip.chip()));
  const std::vector<std::string> want = {"period", "polarity", "duty_cycle", "enable"};
  EXPECT_EQ(SetUpWrites(chip, &pwm, &error), want);
  EXPECT_EQ(chip.Attr("period"), "40000");
  EXPECT_EQ(chip.Attr("duty_cycle"), "2000");
}

// The profile's duty range and slew limit: [0, 2] A onto [5 %, 95 %], 1 A per ms at most; the
// safe state is never rate-limited.
TEST(PwmDeviceTest, DutyRangeAndSlewLimitOfTheProfile) {
  FakePwmChip chip(true);
  PwmConfig cfg;
  cfg.chip = chip.chip();
  cfg.profile.period_ns = 40'000;
  cfg.profile.min_duty = 0.05;
  cfg.profile.max_duty = 0.95;
  std::string error;
  ASSERT_TRUE(cfg.profile.command.SetRange(0.0, 2.0, 1000.0, &error)) << error;
  cfg.period_s = 1e-3;
  PwmDevice pwm(cfg);
  ASSERT_TRUE(pwm.Configure(&error)) << error;
  ASSERT_TRUE(pwm.Activate(&error)) << error;
  EXPECT_EQ(chip.Attr("duty_cycle"), "2000");  // 0 A: 5 %
  IoError why = IoError::kNone;
  EXPECT_EQ(pwm.Write(::mrd::test::NowIo(), {2.0, true, false, 1}, &why), IoStatus::kOk);
  EXPECT_EQ(chip.Attr("duty_cycle"), "20000");  // 1 A after one period: 50 %
  EXPECT_EQ(pwm.Write(::mrd::test::NowIo(), {2.0, true, false, 2}, &why), IoStatus::kOk);
  EXPECT_EQ(chip.Attr("duty_cycle"), "38000");  // 2 A: 95 %
  EXPECT_EQ(pwm.Write(::mrd::test::NowIo(), {0.0, false, true, 3}, &why), IoStatus::kOk);
  EXPECT_EQ(chip.Attr("duty_cycle"), "2000");  // safe: at once
  EXPECT_EQ(pwm.last_duty_ns(), 2000);
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
  ASSERT_TRUE(cfg.profile.command.LoadCalibration(cal, &error)) << error;
  PwmDevice pwm(cfg);
  ASSERT_TRUE(pwm.Configure(&error)) << error;
  ASSERT_TRUE(pwm.Activate(&error)) << error;
  IoError why = IoError::kNone;
  test::AllocationGuard guard;
  for (int k = 0; k < 1000; ++k) {
    (void)pwm.Write(::mrd::test::NowIo(),
                    {2.25 * (k % 10) / 9.0, true, false, static_cast<std::uint64_t>(k)}, &why);
  }
  EXPECT_EQ(guard.count(), 0U);
  EXPECT_EQ(pwm.Write(::mrd::test::NowIo(), {1.125, true, false, 1000}, &why),
            IoStatus::kOk);  // 50 %
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
  EXPECT_EQ(broken.Write(::mrd::test::NowIo(), {1.0, true, false, 1}, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kSystem);
}

// The device as the firmware builds it from [pwm] (MakePwmDevice), behind FieldbusIo: a
// period's command and safe state allocate nothing.
TEST(PwmDeviceTest, FieldbusPeriodsThroughTheConfiguredDeviceAllocateNothing) {
  char dir[] = "/tmp/mrd-pwmsysfs-XXXXXX";
  const std::string root = mkdtemp(dir);
  mkdir((root + "/pwmchip3").c_str(), 0755);
  mkdir((root + "/pwmchip3/pwm1").c_str(), 0755);
  for (const char* f : {"period", "duty_cycle", "enable", "polarity"}) {
    std::ofstream(root + "/pwmchip3/pwm1/" + f) << "0\n";
  }
  auto profile = std::make_shared<profile::PwmProfile>();
  std::string error;
  ASSERT_TRUE(profile::LoadPwmProfile(
      std::string(MRD_SOURCE_DIR) + "/firmware/profiles/pwm-enable.toml", profile.get(), &error))
      << error;
  IoConfig io;
  io.pwm.enabled = true;
  io.pwm.outputs = Bit(Output::kCommand);
  io.pwm.sysfs = root;
  io.pwm.chip = 3;
  io.pwm.channel = 1;
  io.pwm.pwm_profile = profile;
  std::vector<std::unique_ptr<BusDevice>> devices;
  ASSERT_TRUE(MakeDevices(io, &devices, &error)) << error;
  ASSERT_EQ(devices.size(), 1U);
  EXPECT_STREQ(devices[0]->name(), "pwm");
  ASSERT_TRUE(devices[0]->Configure(&error)) << error;
  ASSERT_TRUE(devices[0]->Activate(&error)) << error;
  FieldbusIo fio;
  ASSERT_TRUE(fio.Add(devices[0].get()));
  std::uint64_t allocations = 0;
  {
    test::AllocationGuard guard;
    for (int k = 0; k < 2000; ++k) {
      const double e = 2.0 * (k % 100) / 100.0;
      const IoStatus s = k % 500 < 10 ? fio.EnterSafeState(::mrd::test::NowIo(), 0.0)
                                      : fio.Command(::mrd::test::NowIo(), e);
      if (s != IoStatus::kOk) ADD_FAILURE() << "period " << k;
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  // pwm-enable: 1.0 V -> 0.2 A (5-ohm coil) -> 0.095 of 50 us.
  EXPECT_EQ(fio.Command(::mrd::test::NowIo(), 1.0), IoStatus::kOk);
  EXPECT_EQ(Slurp(root + "/pwmchip3/pwm1/duty_cycle").substr(0, 5), "4750\n");
  devices[0]->Deactivate();
  (void)!system(("rm -rf " + root).c_str());
}

}  // namespace
}  // namespace mrd::firmware
