#include "mrd/hil/ports/gpio_sim_port.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>

#include "mrd/common/clock.hpp"
#include "mrd/protocol/quadrature.hpp"

namespace mrd::hil {
namespace {

bool ReadLine(const std::string& path, std::string* out) {
  std::ifstream in(path);
  if (!in || !std::getline(in, *out) || out->empty()) return false;
  return true;
}

class GpioSimPort final : public PlantPort {
 public:
  explicit GpioSimPort(GpioPortConfig config) : c_(std::move(config)) {}
  ~GpioSimPort() override { Close(); }

  const char* name() const override { return "gpio-sim"; }

  bool Open(std::string* error) override {
    Close();
    std::string chip, dev;
    if (!GpioSimChipName(c_.path, &chip, error)) return false;
    if (!ReadLine(c_.path + "/dev_name", &dev)) {
      *error = c_.path + "/dev_name: cannot read (is the gpio-sim device live?)";
      return false;
    }
    const std::string dir = "/sys/devices/platform/" + dev + "/" + chip + "/sim_gpio";
    const auto open = [&](int line, const char* attr, int flags, int* fd) {
      const std::string p = dir + std::to_string(line) + "/" + attr;
      *fd = ::open(p.c_str(), flags | O_CLOEXEC);
      if (*fd < 0) *error = p + ": " + std::strerror(errno);
      return *fd >= 0;
    };
    if (!open(c_.encoder_a_line, "pull", O_RDWR, &a_) ||
        !open(c_.encoder_b_line, "pull", O_RDWR, &b_) ||
        !open(c_.fault_line, "pull", O_RDWR, &fault_) ||
        !open(c_.enable_line, "value", O_RDONLY, &enable_fd_) ||
        !open(c_.heartbeat_line, "value", O_RDONLY, &heartbeat_fd_)) {
      Close();
      return false;
    }
    if (!SetPull(fault_, c_.fault_active_low)) {  // not asserted
      *error = "gpio-sim: cannot set the fault line";
      Close();
      return false;
    }
    fault_level_ = c_.fault_active_low;
    // Continue from the levels the chip holds.
    const int a = ReadPull(a_), b = ReadPull(b_);
    if (a < 0 || b < 0) {
      *error = "gpio-sim: cannot read the encoder lines' pull";
      Close();
      return false;
    }
    count_ = 0;
    while (protocol::LevelsForCount(count_).a != (a != 0) ||
           protocol::LevelsForCount(count_).b != (b != 0)) {
      ++count_;
    }
    heartbeat_ = ReadValue(heartbeat_fd_);
    return true;
  }

  void Publish(const SensorOutput& out) override {
    if (a_ < 0) return;
    const bool fault = out.fault_line != c_.fault_active_low;
    if (fault != fault_level_ && SetPull(fault_, fault)) fault_level_ = fault;
    const std::int64_t steps = EncoderStepsToward(out.sample.x, c_.counts_per_cm, count_);
    const std::int64_t dir = steps > 0 ? 1 : -1;
    for (std::int64_t i = 0; i != steps; i += dir) {
      const protocol::QuadratureLevels from = protocol::LevelsForCount(count_);
      const protocol::QuadratureLevels to = protocol::LevelsForCount(count_ + dir);
      // One line changes per quadrature step.
      const bool ok = to.a != from.a ? SetPull(a_, to.a) : SetPull(b_, to.b);
      if (!ok) {
        ++failed_;
        return;
      }
      count_ += dir;
      ++published_;
    }
  }

  void Poll(DriverInput* in) override {
    if (a_ < 0) return;
    const int enable = ReadValue(enable_fd_);
    if (enable >= 0) {
      if ((enable != 0) != enable_) ++received_;
      enable_ = enable != 0;
      in->has_enable = true;
      in->enable = enable_;
    }
    const int hb = ReadValue(heartbeat_fd_);
    if (hb >= 0 && hb != heartbeat_) {
      heartbeat_ = hb;
      ++received_;
      ++in->heartbeats;
      in->heartbeat_ns = common::MonotonicNs();
    }
  }

  void Close() override {
    for (int* fd : {&a_, &b_, &fault_, &enable_fd_, &heartbeat_fd_}) {
      if (*fd >= 0) ::close(*fd);
      *fd = -1;
    }
  }
  PortCounters counters() const override { return {published_, received_, failed_}; }

 private:
  static bool SetPull(int fd, bool high) {
    const char* v = high ? "pull-up" : "pull-down";
    const auto n = static_cast<ssize_t>(std::strlen(v));
    return ::pwrite(fd, v, static_cast<std::size_t>(n), 0) == n;
  }
  // 1, 0, or -1 on a failed read.
  static int ReadPull(int fd) {
    char buf[16] = {};
    if (::pread(fd, buf, sizeof buf - 1, 0) <= 0) return -1;
    return std::strncmp(buf, "pull-up", 7) == 0 ? 1 : 0;
  }
  static int ReadValue(int fd) {
    char buf[8] = {};
    if (::pread(fd, buf, sizeof buf - 1, 0) <= 0) return -1;
    return buf[0] == '1' ? 1 : buf[0] == '0' ? 0 : -1;
  }

  GpioPortConfig c_;
  int a_ = -1, b_ = -1, fault_ = -1, enable_fd_ = -1, heartbeat_fd_ = -1;
  std::int64_t count_ = 0;
  bool fault_level_ = false, enable_ = false;
  int heartbeat_ = -1;
  std::uint64_t published_ = 0, received_ = 0, failed_ = 0;
};

}  // namespace

bool GpioSimChipName(const std::string& configfs_dir, std::string* name, std::string* error) {
  if (!ReadLine(configfs_dir + "/bank0/chip_name", name)) {
    *error = configfs_dir + "/bank0/chip_name: cannot read (a live gpio-sim device with bank0?)";
    return false;
  }
  return true;
}

std::unique_ptr<PlantPort> MakeGpioSimPort(const GpioPortConfig& config) {
  return std::make_unique<GpioSimPort>(config);
}

}  // namespace mrd::hil
