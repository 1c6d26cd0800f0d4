#pragma once
// Where each signal comes from and where each output goes, with the connection settings of
// each bus (the [can], [modbus] and [gpio] sections of the firmware configuration; reference:
// docs/firmware_config.md). Plain data; start-up only.
//
// Each bus section lists the inputs it serves and the outputs it drives:
//   [can]     inputs  velocity displacement demand body_velocity force fault_line
//                     body_acceleration wheel_velocity
//                     floor_acceleration_1 floor_acceleration_2 floor_acceleration_3
//             outputs command enable heartbeat status   (in the device profile's messages)
//   [modbus]  inputs  velocity displacement demand body_velocity force fault_line
//                     body_acceleration wheel_velocity floor_acceleration_1..3
//                     (these five through a profile only)
//             outputs command enable heartbeat status
//   [gpio]    inputs  fault_line displacement (quadrature encoder)
//             outputs enable heartbeat
//   [pwm]     outputs command   (sysfs PWM; the duty through the profile's [pwm] section)
// An input served by two buses, an output driven by two (heartbeat and status excepted: they
// may go out on several), a required input that no bus serves, or no command output: refused.
// With no bus section the loop runs the built-in simulated damper (dry run).

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "mrd/firmware/signals.hpp"  // Input, Output, Bit

namespace mrd::profile {
struct CanProfile;
struct ModbusProfile;
struct PwmProfile;
}  // namespace mrd::profile

namespace mrd::firmware {

struct CanConfig {
  bool enabled = false;
  std::uint32_t inputs = 0;   // Bit(Input)
  std::uint32_t outputs = 0;  // Bit(Output)
  // Exactly one of: a SocketCAN interface (CAN_RAW socket with receive filters; a board) or
  // the UNIX socket path of a local frame bus (mrd-canbus; build machines without AF_CAN).
  std::string interface;
  std::string local_bus;
  // The device profile: the file ("" : the built-in mrd-native one), loaded and checked with
  // the configuration (the pointer; empty for mrd-native).
  std::string profile;
  std::shared_ptr<const profile::CanProfile> can_profile;
  std::int64_t tx_deadline_ns = 500'000;        // a frame not sent by then is dropped [ns]
  std::int64_t period_ns = 1'000'000;           // the control period (the command's slew step) [ns]
  std::int64_t status_period_ns = 100'000'000;  // status frame period [ns]
  std::int64_t heartbeat_period_ns = 10'000'000;  // heartbeat frame period [ns]
  std::int64_t fault_reset_ns = 1'000'000'000;    // fault_reset: at most one edge per this [ns]
  // Lockstep ([loop] clock = "grant"): the device is the loop's TimeGrantSource, stamps and
  // schedules in granted time instead of CLOCK_MONOTONIC. Not a [can] key: set from [loop].
  bool lockstep = false;
  // [safety] max_age_ms: no driving command leaves on a sensor sample older than this [ns].
  // Not a [can] key: set from [safety].
  std::int64_t max_age_ns = 5'000'000;
  // Several channels on one bus ([channels] can_profiles), not [can] keys: set per channel's
  // device by the start-up. node_frames: this device produces the firmware node's CANopen
  // heartbeat and SYNC (channel 0's only: one node, one heartbeat). grant_follower (lockstep):
  // not the loop's grant source; Read first waits, at most follower_wait_ns of wall time
  // ([loop] grant_timeout_ms), until this device's own socket has delivered the grant of the
  // loop's tick (can_device.hpp).
  const char* name = "can";  // the device's name in the summary (channel i > 0: "can<i>")
  bool node_frames = true;
  bool grant_follower = false;
  std::int64_t follower_wait_ns = 5'000'000'000;
  // Ends a follower's wait early when set (the firmware's stop request); nullptr: none.
  const std::atomic<bool>* stop = nullptr;
};

enum class ModbusMode : std::uint8_t { kTcp = 0, kRtu };

struct ModbusConfig {
  bool enabled = false;
  std::uint32_t inputs = 0;
  std::uint32_t outputs = 0;
  ModbusMode mode = ModbusMode::kTcp;
  std::string host = "127.0.0.1";  // TCP
  int port = 502;                  // TCP
  std::string device;              // RTU serial device, e.g. /dev/ttyS1
  int baud = 115200;               // RTU
  char parity = 'N';               // RTU: N, E or O
  int data_bits = 8;               // RTU
  int stop_bits = 1;               // RTU
  int slave = 1;                   // unit / slave id (1-247); a profile names its own
  // The Modbus device profile: the file ("": the built-in map of docs/modbus_registers.md),
  // loaded and checked with the configuration (the pointer; empty for the built-in map).
  std::string profile;
  std::shared_ptr<const profile::ModbusProfile> modbus_profile;
  std::int64_t period_ns = 1'000'000;  // the control period (the command's slew step) [ns]
  std::int64_t response_timeout_ns = 20'000'000;  // per request [ns]
  int retries = 1;  // extra attempts per transaction after a timeout or CRC error
  std::int64_t poll_period_ns = 1'000'000;  // worker's read/write cycle [ns]
  // Lockstep ([loop] clock = "grant" without a [can] bus): the device is the loop's
  // TimeGrantSource (the grant register, docs/modbus_registers.md). Set from [loop].
  bool lockstep = false;
  // SCHED_FIFO priority of the worker thread, the loop's ([loop] priority; 0: normal), so a
  // safe block the loop posts is on the wire within the periods the loop itself keeps.
  int priority = 0;
};

struct GpioConfig {
  bool enabled = false;
  std::uint32_t inputs = 0;
  std::uint32_t outputs = 0;
  // Exactly one of: a GPIO character device (libgpiod, e.g. "gpiochip0" or "/dev/gpiochip0")
  // or the path of a simulated chip shared with a test peer or the HIL harness.
  std::string chip;
  std::string sim_chip;
  int enable_line = -1;  // output offsets; -1: not wired
  int heartbeat_line = -1;
  int fault_line = -1;  // input offsets
  int encoder_a_line = -1;
  int encoder_b_line = -1;
  bool fault_active_low = false;
  double counts_per_cm = 400.0;  // quadrature counts (4 per encoder line cycle) per cm
};

// The set-point as a PWM duty through the kernel's sysfs PWM interface (docs/devices.md).
struct PwmOutputConfig {
  bool enabled = false;
  std::uint32_t outputs = 0;             // Bit(Output::kCommand) only
  std::string sysfs = "/sys/class/pwm";  // the class directory (tests: a tree of the same ABI)
  int chip = 0;                          // pwmchipN
  int channel = 0;                       // pwmM of that chip
  // The device profile with the [pwm] section ("": the [can] section's profile file), loaded
  // with the configuration.
  std::string profile;
  std::shared_ptr<const profile::PwmProfile> pwm_profile;
  // Not [pwm] keys: the control period (the command's slew step) and [safety] safe_voltage
  // (the duty the channel starts with).
  std::int64_t period_ns = 1'000'000;
  double safe_volts = 0.0;
};

struct IoConfig {
  CanConfig can;
  ModbusConfig modbus;
  GpioConfig gpio;
  PwmOutputConfig pwm;
  // True when any bus section is present (else: the simulated damper).
  bool any() const { return can.enabled || modbus.enabled || gpio.enabled || pwm.enabled; }
};

}  // namespace mrd::firmware
