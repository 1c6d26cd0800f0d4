#pragma once
// The [canopen] section of a CAN device profile: a CiA 301 drive on the bus (docs/devices.md,
// "CANopen drives"). The drive's PDOs are ordinary messages of the profile's DBC (static
// mapping: RPDO1 0x200 + node the set-point, TPDO1 0x180 + node its status); this section adds
// the network management around them:
//
//   [canopen]
//   node_id = 5                       the drive's node id (1..127)
//   own_node_id = 1                   the firmware's node id as heartbeat producer (1..127)
//   heartbeat_ms = 10                 producer heartbeat period (0: none; default 10)
//   drive_heartbeat_timeout_ms = 50   the drive's heartbeat missing this long, or a state
//                                     other than operational: driver fault (0: not watched;
//                                     default 100)
//   nmt_start = true                  NMT "start remote node" at start-up and after a boot-up
//   sync_period_ms = 0                SYNC (0x080) period (0: none)
//   sdo_timeout_ms = 100              per SDO download at start-up
//   [[canopen.sdo]]                   expedited downloads at start-up, in order, each checked
//   name = "modes of operation: current"
//   index = 0x6060   subindex = 0   size = 1 (1, 2 or 4 bytes)   value = -3
//
// Refused with FILE:LINE: reason: node ids out of range or equal, a size other than 1, 2, 4,
// a value that does not fit its size, an index below 0x1000, a duplicate name or
// index:subindex, an unknown key, and a message the profile uses whose standard id is one of
// the CANopen COB-IDs of the two nodes (NMT 0x000, SYNC 0x080, EMCY 0x080 + node, SDO 0x580 /
// 0x600 + node, heartbeat 0x700 + node of either node).

#include <cstdint>
#include <string>
#include <vector>

namespace mrd::profile {

struct SdoDownload {
  std::string name;  // shown in errors ("modes of operation: current")
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  int size = 1;            // bytes: 1, 2 or 4
  std::int64_t value = 0;  // fits `size` bytes, signed or unsigned
  int line = 0;            // in the profile file
};

struct CanopenConfig {
  int node_id = 0;                                        // the drive
  int own_node_id = 0;                                    // the firmware (heartbeat producer)
  std::int64_t heartbeat_ns = 10'000'000;                 // 0: no heartbeat produced
  std::int64_t drive_heartbeat_timeout_ns = 100'000'000;  // 0: the drive's not watched
  bool nmt_start = true;
  std::int64_t sync_period_ns = 0;  // 0: no SYNC
  std::int64_t sdo_timeout_ns = 100'000'000;
  std::vector<SdoDownload> sdo;
};

// "'modes of operation: current' 0x6060:00 = -3" (the entry as errors name it).
std::string DescribeSdo(const SdoDownload& sdo);
// "drive refused SDO 'modes of operation: current' 0x6060:00 = -3: abort 0x06090030 value
// range of parameter exceeded".
std::string SdoRefusalMessage(const SdoDownload& sdo, std::uint32_t abort_code);

}  // namespace mrd::profile
