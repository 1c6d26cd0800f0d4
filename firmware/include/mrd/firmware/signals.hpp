#pragma once
// The core's signals: the inputs the loop reads (SensorFrame, io.hpp) and the outputs it
// drives, each as a bit of a routing mask. Which bus serves which signal is the I/O side's
// business (mrd/firmware/io/io_config.hpp); the core sees only these enums.

#include <cstddef>
#include <cstdint>

namespace mrd::firmware {

// Inputs a device can serve (bit i = 1 << Input i).
enum class Input : std::uint8_t {
  kVelocity = 0,
  kDisplacement,
  kDemand,
  kBodyVelocity,
  kForce,
  kFaultLine,
  kBodyAcceleration,    // [cm/s^2] (ADD, SH-ADD)
  kWheelVelocity,       // [cm/s] (groundhook, hybrid)
  kFloorAcceleration1,  // absolute floor accelerations [m/s^2] (clipped-optimal)
  kFloorAcceleration2,
  kFloorAcceleration3,
};
// Each input with its profile role: mrd/firmware/io/input_roles.hpp.
inline constexpr std::size_t kNumInputs = 11;
// Outputs a device can drive.
enum class Output : std::uint8_t {
  kCommand = 0,  // voltage set-point to the current driver
  kEnable,       // driver enable (low in the safe state)
  kHeartbeat,    // liveness signal the driver watches (stops when the firmware dies)
  kStatus,       // firmware status / telemetry
};
inline constexpr std::size_t kNumOutputs = 4;
constexpr std::uint32_t Bit(Input i) { return 1U << static_cast<unsigned>(i); }
constexpr std::uint32_t Bit(Output o) { return 1U << static_cast<unsigned>(o); }
// Config names ("velocity", "displacement", "demand", "body_velocity", "force", "fault_line",
// "body_acceleration", "wheel_velocity", "floor_acceleration_1", "floor_acceleration_2",
// "floor_acceleration_3"; "command", "enable", "heartbeat", "status"). Defined with the
// devices (mrd::firmware_io, bus_device.cpp): only the configuration and the devices name
// signals; the core never calls these.
const char* InputName(Input input);
const char* OutputName(Output output);

}  // namespace mrd::firmware
