#include "mrd/firmware/io/pwm/pwm_device.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>

#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/devices.hpp"

namespace mrd::firmware {
namespace {

// Writes a value and a newline to a sysfs attribute in one write (the kernel parses up to the
// newline); false with *error.
bool WriteAttr(const std::string& path, const char* text, std::string* error) {
  const int fd = open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    *error = "pwm: cannot open " + path + ": " + std::strerror(errno);
    return false;
  }
  char buf[64];
  const int len = std::snprintf(buf, sizeof buf, "%s\n", text);
  const auto n = static_cast<ssize_t>(len);
  const bool ok = len > 0 && static_cast<std::size_t>(len) < sizeof buf &&
                  write(fd, buf, static_cast<std::size_t>(n)) == n;
  const int e = errno;
  close(fd);
  if (!ok)
    *error = "pwm: cannot write '" + std::string(text) + "' to " + path + ": " + std::strerror(e);
  return ok;
}

// Reads a numeric sysfs attribute (a decimal number and a newline); false with *error.
bool ReadAttr(const std::string& path, std::int64_t* value, std::string* error) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  char buf[32] = {};
  const ssize_t n = fd >= 0 ? read(fd, buf, sizeof buf - 1) : -1;
  const int e = errno;
  if (fd >= 0) close(fd);
  char* end = nullptr;
  const long long v = n > 0 ? std::strtoll(buf, &end, 10) : -1;
  if (n <= 0 || end == buf || (*end != '\n' && *end != '\0') || v < 0) {
    *error = "pwm: cannot read a number from " + path +
             (n < 0 ? ": " + std::string(std::strerror(e)) : "");
    return false;
  }
  *value = v;
  return true;
}

}  // namespace

PwmDevice::PwmDevice(const PwmConfig& config) : config_(config), map_(config.profile.command) {
  dir_ = config_.chip + "/pwm" + std::to_string(config_.channel);
}

PwmDevice::~PwmDevice() { Deactivate(); }

bool PwmDevice::Configure(std::string* error) {
  struct stat st {};
  if (config_.chip.empty() || stat(config_.chip.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    *error = "pwm: chip '" + config_.chip + "' is not a sysfs PWM chip directory";
    return false;
  }
  const profile::PwmProfile& p = config_.profile;
  if (config_.channel < 0 || p.period_ns <= 0 || !(p.min_duty >= 0.0) || !(p.max_duty <= 1.0) ||
      !(p.min_duty < p.max_duty) || !(p.command.min() < p.command.max())) {
    *error =
        "pwm: channel >= 0, period > 0, 0 <= min_duty < max_duty <= 1 and a command range "
        "required";
    return false;
  }
  if (stat(dir_.c_str(), &st) != 0) {
    if (!WriteAttr(config_.chip + "/export", std::to_string(config_.channel).c_str(), error)) {
      return false;
    }
    // The kernel creates pwmN at once; udev may take a moment to make its files writable.
    const std::int64_t until = common::MonotonicNs() + kExportWaitNs;
    while (access((dir_ + "/enable").c_str(), W_OK) != 0) {
      if (common::MonotonicNs() > until) {
        *error = "pwm: " + dir_ + " did not appear (or stayed unwritable) within 1 s of export";
        return false;
      }
      usleep(5000);
    }
  }
  // The kernel applies each attribute write as a whole state and refuses one with period 0
  // or duty > period. A fresh channel (period 0, disabled) takes the period first; one an
  // earlier user left running is disabled and its duty zeroed before the new period.
  std::int64_t old_period = 0;
  if (!ReadAttr(dir_ + "/period", &old_period, error)) return false;
  if (old_period != 0) {
    if (!WriteAttr(dir_ + "/enable", "0", error)) return false;
    if (!WriteAttr(dir_ + "/duty_cycle", "0", error)) return false;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(p.period_ns));
  if (!WriteAttr(dir_ + "/period", buf, error)) return false;
  if (!WriteAttr(dir_ + "/polarity", p.inversed ? "inversed" : "normal", error)) return false;
  duty_fd_ = open((dir_ + "/duty_cycle").c_str(), O_WRONLY | O_CLOEXEC);
  enable_fd_ = open((dir_ + "/enable").c_str(), O_WRONLY | O_CLOEXEC);
  if (duty_fd_ < 0 || enable_fd_ < 0) {
    *error = "pwm: cannot open " + dir_ + "/duty_cycle or enable: " + std::strerror(errno);
    return false;
  }
  return true;
}

bool PwmDevice::WriteDuty(std::int64_t duty_ns) {
  if (duty_ns == last_duty_ns_) return true;
  char buf[24];
  const int n = std::snprintf(buf, sizeof buf, "%lld\n", static_cast<long long>(duty_ns));
  if (duty_fd_ < 0 || pwrite(duty_fd_, buf, static_cast<std::size_t>(n), 0) != n) {
    ++counters_.tx_failed;
    ++counters_.errors[static_cast<std::size_t>(IoError::kSystem)];
    counters_.last_error = IoError::kSystem;
    last_duty_ns_ = -1;  // unknown now: write again next time
    return false;
  }
  ++counters_.tx_ok;
  last_duty_ns_ = duty_ns;
  return true;
}

std::int64_t PwmDevice::DutyOf(double volts, bool safe) {
  if (safe) map_.Reset();  // the safe state is never rate-limited
  const double u = map_.Apply(volts, config_.period_s);
  return config_.profile.DutyNs(config_.profile.SetpointToDuty(u));
}

bool PwmDevice::Activate(std::string* error) {
  last_duty_ns_ = -1;
  if (!WriteDuty(DutyOf(config_.safe_volts, true)) || pwrite(enable_fd_, "1\n", 2, 0) != 2) {
    *error = "pwm: cannot start " + dir_ + ": " + std::strerror(errno);
    return false;
  }
  active_ = true;
  return true;
}

void PwmDevice::Deactivate() {
  if (duty_fd_ >= 0) {
    (void)WriteDuty(0);
    if (enable_fd_ >= 0) (void)!pwrite(enable_fd_, "0\n", 2, 0);
  }
  if (duty_fd_ >= 0) close(duty_fd_);
  if (enable_fd_ >= 0) close(enable_fd_);
  duty_fd_ = enable_fd_ = -1;
  active_ = false;
}

IoStatus PwmDevice::Read(const IoTime& t, SensorFrame* frame, IoError* why) {
  (void)t;
  (void)frame;
  (void)why;
  return IoStatus::kNoData;
}

IoStatus PwmDevice::Write(const IoTime& t, const DriverCommand& cmd, IoError* why) {
  (void)t;
  // A non-finite command maps to the range's low end (CommandMap::Apply); never wrapped.
  const std::int64_t ns = DutyOf(cmd.volts, cmd.safe);
  if (!active_ || !WriteDuty(ns)) {
    *why = IoError::kSystem;
    return IoStatus::kFault;
  }
  return IoStatus::kOk;
}

std::unique_ptr<BusDevice> MakePwmDevice(const PwmOutputConfig& config) {
  if (config.pwm_profile == nullptr) return nullptr;
  PwmConfig c;
  c.enabled = config.enabled;
  c.chip = config.sysfs + "/pwmchip" + std::to_string(config.chip);
  c.channel = config.channel;
  c.profile = *config.pwm_profile;
  c.safe_volts = config.safe_volts;
  c.period_s = static_cast<double>(config.period_ns) * 1e-9;
  return std::make_unique<PwmDevice>(c);
}

}  // namespace mrd::firmware
