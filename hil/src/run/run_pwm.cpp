#include "run_pwm.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>

namespace mrd::hil {

bool RunPwm::Open(const std::string& profile_path, const std::string& work_dir, std::string* sysfs,
                  std::string* error) {
  if (!profile::ProfileHasPwm(profile_path)) return true;
  if (!profile::LoadPwmProfile(profile_path, &profile_, error)) return false;
  // The class directory, one chip with one channel already exported (the firmware exports
  // only when pwmM is absent), every attribute as the kernel shows a fresh channel: disabled,
  // duty 0, period 0, normal polarity.
  const std::string root = work_dir + "/pwm-sysfs";
  const std::string chip = root + "/pwmchip0";
  const std::string ch = chip + "/pwm0";
  for (const std::string& d : {root, chip, ch}) {
    if (mkdir(d.c_str(), 0755) != 0 && errno != EEXIST) {
      *error = d + ": cannot create (" + std::strerror(errno) + ")";
      return false;
    }
  }
  std::ofstream(chip + "/npwm") << "1\n";
  std::ofstream(chip + "/export") << "";
  std::ofstream(chip + "/unexport") << "";
  for (const char* f : {"period", "duty_cycle", "enable"}) std::ofstream(ch + "/" + f) << "0\n";
  std::ofstream(ch + "/polarity") << "normal\n";
  period_fd_ = open((ch + "/period").c_str(), O_RDONLY | O_CLOEXEC);
  duty_fd_ = open((ch + "/duty_cycle").c_str(), O_RDONLY | O_CLOEXEC);
  enable_fd_ = open((ch + "/enable").c_str(), O_RDONLY | O_CLOEXEC);
  polarity_fd_ = open((ch + "/polarity").c_str(), O_RDONLY | O_CLOEXEC);
  if (period_fd_ < 0 || duty_fd_ < 0 || enable_fd_ < 0 || polarity_fd_ < 0) {
    *error = ch + ": cannot open the channel's attributes (" + std::strerror(errno) + ")";
    Close();
    return false;
  }
  *sysfs = root;
  active_ = true;
  return true;
}

// The attribute's value up to its first newline (a regular file, unlike sysfs, keeps the tail
// of a longer earlier value after it): a number into *value, else the word into *text.
bool RunPwm::ReadAttr(int fd, std::int64_t* value, std::string* text) {
  char buf[64];
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  if (n <= 0) return false;
  buf[n] = '\0';
  char* nl = std::strchr(buf, '\n');
  if (nl == nullptr) return false;  // a write in progress (real time): not a value yet
  *nl = '\0';
  if (text != nullptr) {
    *text = buf;
    return true;
  }
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(buf, &end, 10);
  if (end == buf || *end != '\0' || errno != 0 || v < 0) return false;
  *value = v;
  return true;
}

void RunPwm::Poll(DriverInput* in) {
  if (!active_) return;
  std::int64_t enable = 0, period = 0, duty = 0;
  std::string polarity;
  if (!ReadAttr(enable_fd_, &enable, nullptr) || !ReadAttr(period_fd_, &period, nullptr) ||
      !ReadAttr(duty_fd_, &duty, nullptr) || !ReadAttr(polarity_fd_, nullptr, &polarity)) {
    ++rejected_;
    return;
  }
  if (enable != 0) started_ = true;
  if (!started_) return;  // the firmware has not set the channel up yet
  in->has_command = true;
  if (enable == 0) {
    in->volts = 0.0;  // a disabled channel: the driver's input sees no pulses
    return;
  }
  if (period != profile_.period_ns || duty > period ||
      polarity != (profile_.inversed ? "inversed" : "normal")) {
    ++rejected_;
    in->volts = 0.0;
    return;
  }
  ++received_;
  duty_ns_ = duty;
  in->volts = profile_.DutyToVolts(duty);
}

double RunPwm::QuantumVolts(double e) const {
  if (!active_) return 0.0;
  const profile::PwmProfile& p = profile_;
  const std::int64_t d = p.DutyNs(p.SetpointToDuty(p.command.Calibrate(e)));
  const double a = p.DutyToVolts(d), b = p.DutyToVolts(d + 1), c = p.DutyToVolts(d - 1);
  return std::max(std::fabs(b - a), std::fabs(a - c));
}

void RunPwm::Close() {
  for (int* fd : {&period_fd_, &duty_fd_, &enable_fd_, &polarity_fd_}) {
    if (*fd >= 0) close(*fd);
    *fd = -1;
  }
  active_ = false;
}

}  // namespace mrd::hil
