#pragma once
// Each channel's model for several damper channels ([channels] count > 1), shared by the dry
// run (dry_channels.hpp) and the bus run (bus_channels.hpp): channel i's table is [channels]
// tables[i] (one SharedModel per distinct file, shared), else the run's table (--table, else
// the compiled-in one) for every channel. Start-up only (allocates).

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "mrd/common/table.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/firmware/shared_model.hpp"

namespace mrd::firmware {

struct ChannelModels {
  std::vector<std::shared_ptr<const SharedModel>> models;  // per channel
  bool any_demo = false;  // a channel runs on the compiled-in demo table (demo_table.hpp)
};

// "" or why a table was refused ("table NAME refused...").
std::string LoadChannelModels(const platform::FirmwareConfig& cfg,
                              const mrd::CoefficientTable& run_table, const char* run_table_name,
                              ChannelModels* out);

// Channel i's table as the summary names it (points into cfg, or run_table_name).
const char* ChannelTableName(const platform::FirmwareConfig& cfg, const char* run_table_name,
                             std::size_t i);

}  // namespace mrd::firmware
