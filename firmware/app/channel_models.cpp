#include "channel_models.hpp"

#include "demo_table.hpp"
#include "mrd/firmware/platform/table_file.hpp"

namespace mrd::firmware {

std::string LoadChannelModels(const platform::FirmwareConfig& cfg,
                              const mrd::CoefficientTable& run_table, const char* run_table_name,
                              ChannelModels* out) {
  const platform::ChannelsConfig& ch = cfg.channels;
  Error e = Error::kOk;
  const auto run_model = SharedModel::Load(run_table, &e);
  if (e != Error::kOk) return std::string("table ") + run_table_name + " refused";
  for (std::size_t i = 0; i < static_cast<std::size_t>(ch.count); ++i) {
    if (ch.table_paths.empty()) {
      out->models.push_back(run_model);
      out->any_demo = out->any_demo || IsDemoTable(run_table);
      continue;
    }
    std::shared_ptr<const SharedModel> same;
    for (std::size_t j = 0; j < i; ++j) {
      if (ch.table_paths[j] == ch.table_paths[i]) same = out->models[j];
    }
    if (!same) {
      std::string why;
      const auto table = platform::LoadTableFile(ch.table_paths[i].c_str(), &why);
      if (table.ok()) same = SharedModel::Load(table.value(), &e);
      if (!table.ok() || e != Error::kOk) return "table " + ch.table_paths[i] + " refused: " + why;
      out->any_demo = out->any_demo || IsDemoTable(table.value());
    }
    out->models.push_back(same);
  }
  return "";
}

const char* ChannelTableName(const platform::FirmwareConfig& cfg, const char* run_table_name,
                             std::size_t i) {
  return cfg.channels.table_paths.empty() ? run_table_name : cfg.channels.tables[i].c_str();
}

}  // namespace mrd::firmware
