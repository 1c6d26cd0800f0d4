#pragma once
// `mrd-hil run --profile FILE` with a profile that has a [pwm] section: the harness plays a
// current driver with a PWM set-point input. It builds a directory tree that follows the
// sysfs PWM ABI in the run's work directory (SYSFS/pwmchip0/{export,unexport,npwm} and
// pwmchip0/pwm0/{period,duty_cycle,enable,polarity}), points the firmware's [pwm] sysfs at it,
// and reads the channel back each step: duty [ns] -> the profile's duty range -> set-point ->
// E [V] through the inverse of the profile's [command] map (PwmProfile::DutyToVolts). A
// disabled channel drives nothing (0 V). The enable and heartbeat are the scenario's GPIO lines
// (forced on for such a profile; run.cpp).
//
// Lockstep: a sysfs write is no frame, so the harness reads the duty of tick k after that
// tick's firmware status frame on CAN: in each tick the firmware writes all its outputs
// (FieldbusIo::Write: CAN, GPIO, then PWM) before it sends the status (Loop::Tick:
// PublishStatus), and it cannot start tick k+1 before the harness grants it. The profile must
// therefore map a firmware status role (the generated configuration sends a status every
// period). Real time: the duty is read as the step finds it.
//
// Checks from the driver's side (PortCounters::rejected): a period or polarity other than the
// profile's, duty_cycle > period, a value that does not parse. received counts the steps a duty
// was read with the channel enabled.

#include <cstdint>
#include <string>

#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/pwm_profile.hpp"

namespace mrd::hil {

class RunPwm {
 public:
  RunPwm() = default;
  RunPwm(const RunPwm&) = delete;
  RunPwm& operator=(const RunPwm&) = delete;
  ~RunPwm() { Close(); }

  // Nothing (and true) when the profile has no [pwm] section. Else loads it and creates the
  // tree under work_dir; *sysfs: the root for the firmware's [pwm] sysfs key. false: *error.
  bool Open(const std::string& profile_path, const std::string& work_dir, std::string* sysfs,
            std::string* error);
  bool active() const { return active_; }
  // The channel as the firmware left it: sets has_command and volts once the firmware has
  // enabled the channel for the first time (before that: nothing heard).
  void Poll(DriverInput* in);
  void Close();
  const char* name() const { return "pwm"; }
  PortCounters counters() const { return {0, received_, rejected_}; }
  // The E step [V] one ns of duty makes near command e [V] (the channel's resolution there): a
  // duty rounded to the nearest ns may stand for up to half of it beyond e (the invariant's
  // bound e_max is checked with that tolerance; run.cpp).
  double QuantumVolts(double e) const;
  // The latest duty read [ns] (-1: none).
  std::int64_t duty_ns() const { return duty_ns_; }

 private:
  bool ReadAttr(int fd, std::int64_t* value, std::string* text);

  bool active_ = false;
  profile::PwmProfile profile_;
  int period_fd_ = -1, duty_fd_ = -1, enable_fd_ = -1, polarity_fd_ = -1;
  bool started_ = false;
  std::int64_t duty_ns_ = -1;
  std::uint64_t received_ = 0, rejected_ = 0;
};

}  // namespace mrd::hil
