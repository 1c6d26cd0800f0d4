#pragma once
// Several damper channels' Modbus maps on one link (one serial line or TCP connection with one
// master): each channel keeps its own profile (its sensor block, its set-point block; every
// one a valid one-channel profile), and the link reads what all of them need in as few
// requests as the maps allow. Planned once at configuration (allocation here only).
//
// Reads: every channel's input points grouped as one profile's are (by unit, table and
// address; a gap of at most ModbusProfile::kMaxGap registers bridged; no request longer than
// max_read), so channels whose blocks sit side by side in one unit's table share a request. A
// register two channels map alike (one grant, one driver_faults word) is read once. Writes
// stay per channel: each channel's own write requests (its command last), channel by channel.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "mrd/profile/modbus_profile.hpp"

namespace mrd::profile {

inline constexpr std::size_t kMaxModbusChannels = 8;

struct ModbusChannelPlan {
  std::vector<ModbusRequest> reads;  // grouped over all channels, in (unit, table, address) order
  // inputs[k][role]: channel k's point with its request and index into `reads`.
  std::vector<std::array<ModbusPoint, kNumCanIn>> inputs;
  // served[q]: bit k set when read request q carries a point of channel k.
  std::vector<std::uint32_t> served;
  int MaxCount() const;  // registers (or bits) the largest read needs
};

// Plans the link's reads for channels[0..n) (1..kMaxModbusChannels maps). false with *error
// "PATH:LINE: reason" (or "modbus channels: reason") when the maps cannot share one link: the
// link-wide keys (word_order, write_function, align32, max_read) differ from channel 0's, or a
// register (coil) one channel writes (output, start-up or periodic write) is another channel's
// output (two masters of one set-point). Identical start-up and periodic writes (one driver's
// watchdog armed from every map) are allowed.
bool PlanModbusChannels(const std::vector<const ModbusProfile*>& channels, ModbusChannelPlan* out,
                        std::string* error);

// The greedy read grouping of one profile (modbus_profile.hpp) over any set of mapped points:
// sets each point's request and index, appends the requests to *out.
void GroupModbusReads(const std::vector<ModbusPoint*>& points, int max_read,
                      std::vector<ModbusRequest>* out);

}  // namespace mrd::profile
