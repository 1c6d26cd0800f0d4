#pragma once
// The devices of several damper channels on one bus (bus_channels.hpp), one per channel, per
// transport:
//   [can] + can_profiles        a CAN device per channel (its profile, its own socket on the
//                               one bus); channel 0's sends the node's heartbeat and SYNC and,
//                               in lockstep, is the grant source; the others follow its grants
//   [modbus] + modbus_profiles  one Modbus link (ModbusChannels: one master, one worker, one
//                               request sequence) and a view of it per channel; channel 0's
//                               view is the grant source (the grant register, read once per
//                               cycle); the link lives as long as any of the views
// Named in the summary "can", "can1", ... or "modbus", "modbus1", ... Start-up only (allocates).

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/platform/config.hpp"

namespace mrd::firmware {

// The bus the channels share: its section's name, the inputs it serves (Bit(Input)), and the
// profile file of channel i as given in [channels].
struct ChannelBus {
  const char* section;  // "can" or "modbus"
  std::uint32_t inputs;
  const std::vector<std::string>* profiles;
};
ChannelBus ChannelBusOf(const platform::FirmwareConfig& cfg);

// cfg.channels.count devices into *out (channel order), not yet configured: "" or the refusal
// (exit 2). stop: ends a CAN follower's wait for its grant (lockstep).
std::string MakeChannelDevices(const platform::FirmwareConfig& cfg, const std::atomic<bool>* stop,
                               std::vector<std::unique_ptr<BusDevice>>* out);

}  // namespace mrd::firmware
