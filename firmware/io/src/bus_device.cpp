#include "mrd/firmware/io/bus_device.hpp"

namespace mrd::firmware {

const char* IoErrorName(IoError error) {
  switch (error) {
    case IoError::kNone:
      return "none";
    case IoError::kTimeout:
      return "timeout";
    case IoError::kCrc:
      return "crc";
    case IoError::kDisconnected:
      return "disconnected";
    case IoError::kBusOff:
      return "bus_off";
    case IoError::kRejectedFrame:
      return "rejected_frame";
    case IoError::kBadValue:
      return "bad_value";
    case IoError::kException:
      return "exception";
    case IoError::kOverflow:
      return "overflow";
    case IoError::kSystem:
      return "system";
  }
  return "unknown";
}

const char* InputName(Input input) {
  switch (input) {
    case Input::kVelocity:
      return "velocity";
    case Input::kDisplacement:
      return "displacement";
    case Input::kDemand:
      return "demand";
    case Input::kBodyVelocity:
      return "body_velocity";
    case Input::kForce:
      return "force";
    case Input::kFaultLine:
      return "fault_line";
    case Input::kBodyAcceleration:
      return "body_acceleration";
    case Input::kWheelVelocity:
      return "wheel_velocity";
    case Input::kFloorAcceleration1:
      return "floor_acceleration_1";
    case Input::kFloorAcceleration2:
      return "floor_acceleration_2";
    case Input::kFloorAcceleration3:
      return "floor_acceleration_3";
  }
  return "unknown";
}

const char* OutputName(Output output) {
  switch (output) {
    case Output::kCommand:
      return "command";
    case Output::kEnable:
      return "enable";
    case Output::kHeartbeat:
      return "heartbeat";
    case Output::kStatus:
      return "status";
  }
  return "unknown";
}

}  // namespace mrd::firmware
