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
// Configure exports the channel when needed (waiting up to 1 s for the kernel, or udev, to make
// its files writable). The kernel refuses any write that leaves period 0 or duty > period, and
// a polarity change while enabled: a fresh channel (period 0) gets the period, then the
// polarity; one an earlier user left with a period is disabled, its duty zeroed, then the
// period and polarity written. Activate
// writes the duty of the safe voltage and enables the channel. Per period Write maps the
// command E [V] through the profile's [command] map (calibration, range, slew; the safe state
// is not slew-limited, as on CAN) and the duty range (pwm_profile.hpp) to duty [ns] and writes
// duty_cycle only when it changed: one pwrite of the value and a newline on a descriptor
// opened at Configure (no allocation). The enable line is not here: it is a [gpio] output (low
// in the safe state). A failed write is kFault (system: the gpio_bus watchdog cause, as the
// board's other local I/O). Deactivate writes duty 0 and disables the channel. Reads nothing
// (no inputs); no reconnection (a PWM chip does not come and go). A firmware that dies leaves
// the channel running at its last duty (the kernel keeps it): see docs/devices.md.

#include <cstdint>
#include <string>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/profile/pwm_profile.hpp"

namespace mrd::firmware {

struct PwmConfig {
  bool enabled = false;
  std::string chip;             // sysfs directory, e.g. /sys/class/pwm/pwmchip0
  int channel = 0;              // M of pwmM
  profile::PwmProfile profile;  // period, polarity, duty range, E -> set-point map
  double safe_volts = 0.0;      // [V] the duty the channel starts with
  double period_s = 1e-3;       // the control period (the map's slew-limit step) [s]
};

class PwmDevice final : public BusDevice {
 public:
  static constexpr std::int64_t kExportWaitNs = 1'000'000'000;

  explicit PwmDevice(const PwmConfig& config);
  ~PwmDevice() override;

  const char* name() const override { return "pwm"; }
  FaultCause fault_cause() const override { return FaultCause::kGpioBus; }
  bool write_faults_are_bus_faults() const override { return true; }
  bool Configure(std::string* error) override;
  bool Activate(std::string* error) override;
  void Deactivate() override;
  IoStatus Read(const IoTime& t, SensorFrame* frame, IoError* why) override;
  IoStatus Write(const IoTime& t, const DriverCommand& cmd, IoError* why) override;
  DeviceCounters counters() const override { return counters_; }

  std::int64_t last_duty_ns() const { return last_duty_ns_; }

 private:
  bool WriteDuty(std::int64_t duty_ns);
  // The duty [ns] for a command (the map's state advances).
  std::int64_t DutyOf(double volts, bool safe);

  PwmConfig config_;
  profile::CommandMap map_;  // config_.profile.command's copy with its slew state
  std::string dir_;          // CHIP/pwmN
  int duty_fd_ = -1;
  int enable_fd_ = -1;
  std::int64_t last_duty_ns_ = -1;
  bool active_ = false;
  DeviceCounters counters_;
};

}  // namespace mrd::firmware
