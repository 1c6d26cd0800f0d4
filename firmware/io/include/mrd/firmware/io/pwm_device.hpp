#pragma once
// The PWM field device: the current driver's set-point as a PWM duty cycle through the
// kernel's sysfs PWM interface (Documentation/ABI/testing/sysfs-class-pwm), for drivers with
// a PWM or filtered-analog input. The driver's enable travels on a GPIO line ([gpio] enable).
//
//   CHIP/export            write the channel number to create CHIP/pwmN (if absent)
//   CHIP/pwmN/period       [ns]        CHIP/pwmN/duty_cycle   [ns], <= period
//   CHIP/pwmN/polarity     "normal" | "inversed" (written while disabled)
//   CHIP/pwmN/enable       0 | 1
//
// Activate exports the channel when needed (waiting up to 1 s for the kernel, or udev, to make
// its files writable), disables it, sets polarity, duty 0, period, then the safe duty, and
// enables it. Per period Write maps the command (the safe duty in the safe state) through the
// CommandMap (E [V] -> duty [%]) and writes duty_cycle only when it changed: one pwrite of the
// value and a newline on a descriptor opened at Activate (no allocation). A failed write is kFault
// (system: the gpio_bus watchdog cause, as the board's other local I/O). Deactivate writes duty
// 0 and disables the channel. Reads nothing (no inputs); no reconnection (a PWM chip does not
// come and go).

#include <cstdint>
#include <string>

#include "mrd/firmware/bus_device.hpp"
#include "mrd/profile/command_map.hpp"

namespace mrd::firmware {

struct PwmConfig {
  bool enabled = false;
  std::string chip;                 // sysfs directory, e.g. /sys/class/pwm/pwmchip0
  int channel = 0;                  // N of pwmN
  std::int64_t period_ns = 50'000;  // PWM period (20 kHz)
  bool inversed = false;            // polarity
  double safe_duty_percent = 0.0;   // duty in the safe state (0: coil off; shutdown is 0)
  profile::CommandMap map;          // E [V] -> duty [%], clamped to [0, 100]
  double period_s = 1e-3;           // the control period (the map's slew-limit step) [s]
};

class PwmDevice final : public BusDevice {
 public:
  static constexpr std::int64_t kExportWaitNs = 1'000'000'000;

  explicit PwmDevice(const PwmConfig& config);
  ~PwmDevice() override;

  const char* name() const override { return "pwm"; }
  FaultCause fault_cause() const override { return FaultCause::kGpioBus; }
  bool Configure(std::string* error) override;
  bool Activate(std::string* error) override;
  void Deactivate() override;
  IoStatus Read(SensorFrame* frame, IoError* why) override;
  IoStatus Write(const DriverCommand& cmd, IoError* why) override;
  DeviceCounters counters() const override { return counters_; }

  std::int64_t last_duty_ns() const { return last_duty_ns_; }

 private:
  bool WriteDuty(std::int64_t duty_ns);

  PwmConfig config_;
  std::string dir_;  // CHIP/pwmN
  int duty_fd_ = -1;
  int enable_fd_ = -1;
  std::int64_t last_duty_ns_ = -1;
  bool active_ = false;
  DeviceCounters counters_;
};

}  // namespace mrd::firmware
