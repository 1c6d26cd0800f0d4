#pragma once
// The [channels] section of the firmware configuration: several damper channels on one loop
// (loop.hpp), each with its table, under one fault policy and an optional law over the whole
// body (modal skyhook over four corners, modal_skyhook.hpp). In this version several channels
// run on the simulated dampers of a dry run only; the parse refuses count > 1 with a bus
// section.

#include <cstdint>
#include <string>
#include <vector>

#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/modal_skyhook.hpp"

namespace mrd::firmware::platform {

enum class BodyLawKind : std::uint8_t { kNone = 0, kModalSkyhook };

struct ChannelsConfig {
  int count = 1;  // 1 .. kMaxChannels
  FaultPolicy fault_policy = FaultPolicy::kAll;
  // Per channel, as given (relative to the config file); empty: the run's table for every
  // channel. table_paths: the same resolved beside the config file (filled by the parse).
  std::vector<std::string> tables;
  std::vector<std::string> table_paths;
  BodyLawKind body_law = BodyLawKind::kNone;
  BodyGeometry geometry;
  ModalGains gains;
  // Bit i: geometry key i was given (cg_to_front_m, cg_to_rear_m, track_front_m,
  // track_rear_m, motion_ratio); modal skyhook needs all of them.
  std::uint32_t geometry_given = 0;
  static constexpr std::uint32_t kAllGeometry = 0x1F;
};

}  // namespace mrd::firmware::platform
