#pragma once
// The [channels] section of the firmware configuration: several damper channels on one loop
// (loop.hpp), each with its table, under one fault policy and an optional law over the whole
// body (modal skyhook over four corners, modal_skyhook.hpp). Several channels run on the
// simulated dampers of a dry run, over one CAN bus with a device profile per channel
// (can_profiles: e.g. four CANopen drives), or over one Modbus link with a register map per
// channel (modbus_profiles: e.g. one driver with four set-points); the parse refuses count > 1
// with [gpio], [pwm] or [ctl], with [can] but without can_profiles, with [modbus] but without
// modbus_profiles, and both lists (one bus for several channels).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/modal_skyhook.hpp"

namespace mrd::profile {
struct CanProfile;
struct ModbusProfile;
}  // namespace mrd::profile

namespace mrd::firmware::platform {

enum class BodyLawKind : std::uint8_t { kNone = 0, kModalSkyhook };

struct ChannelsConfig {
  int count = 1;  // 1 .. kMaxChannels
  FaultPolicy fault_policy = FaultPolicy::kAll;
  // Per channel, as given (relative to the config file); empty: the run's table for every
  // channel. table_paths: the same resolved beside the config file (filled by the parse).
  std::vector<std::string> tables;
  std::vector<std::string> table_paths;
  // Per channel, the [can] device profile file as given (relative to the config file); empty:
  // one channel on the [can] section's profile. can_device_profiles: the same loaded and
  // checked against the [can] routing (filled by the parse).
  std::vector<std::string> can_profiles;
  std::vector<std::shared_ptr<const profile::CanProfile>> can_device_profiles;
  // Per channel, the [modbus] register map file as given (relative to the config file); empty:
  // one channel on the [modbus] section's profile. modbus_device_profiles: the same loaded,
  // checked against the [modbus] routing and planned on one link (filled by the parse).
  std::vector<std::string> modbus_profiles;
  std::vector<std::shared_ptr<const profile::ModbusProfile>> modbus_device_profiles;
  BodyLawKind body_law = BodyLawKind::kNone;
  BodyGeometry geometry;
  ModalGains gains;
  // Bit i: geometry key i was given (cg_to_front_m, cg_to_rear_m, track_front_m,
  // track_rear_m, motion_ratio); modal skyhook needs all of them.
  std::uint32_t geometry_given = 0;
  static constexpr std::uint32_t kAllGeometry = 0x1F;
};

}  // namespace mrd::firmware::platform
