#include "table_check.hpp"

#include <cstdio>

#include "mrd/common/input_file.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/table_file.hpp"
#include "mrd/hil/model_plant.hpp"

namespace mrd::hil {

bool TableIsUsable(const std::string& path) {
  CoefficientTable table;
  return LoadRunTable(path, &table);
}

bool LoadRunTable(const std::string& path, CoefficientTable* table) {
  if (path.empty()) {
    *table = firmware::kBuiltinTable;
    return true;
  }
  std::string reason;
  const auto loaded = firmware::LoadTableFile(path.c_str(), &reason);
  if (loaded.ok()) {
    *table = loaded.value();
    return true;
  }
  std::fprintf(stderr, "error: %s: %s\n", Printable(path).c_str(), reason.c_str());
  return false;
}

std::string TableLabel(const std::string& path, const CoefficientTable& table) {
  const auto image = EncodeTable(table);
  char crc[32] = "CRC-32 n/a";
  if (image.ok()) {
    const auto& b = image.value();
    const std::uint32_t v = static_cast<std::uint32_t>(b[kTableCrcOffset]) |
                            static_cast<std::uint32_t>(b[kTableCrcOffset + 1]) << 8 |
                            static_cast<std::uint32_t>(b[kTableCrcOffset + 2]) << 16 |
                            static_cast<std::uint32_t>(b[kTableCrcOffset + 3]) << 24;
    std::snprintf(crc, sizeof crc, "CRC-32 0x%08X", static_cast<unsigned>(v));
  }
  return (path.empty() ? std::string("compiled-in") : Printable(path)) + " (" + crc + ")";
}

std::string PlantLabel(const Scenario& s) {
  if (s.plant_model) {
    return "NARX model " + Printable(s.plant_model->file) + " (iteration " +
           std::to_string(s.plant_model->iteration) + ")";
  }
  std::string damper = s.params_file.empty() ? "Spencer damper, preset " + Printable(s.preset)
                                             : "Spencer damper, params " + Printable(s.params_file);
  if (s.plant_overrides) damper += " + [plant.spencer] overrides";
  if (s.quarter_car) return "quarter car, " + damper;
  if (s.structure) return "three-story structure, " + damper;
  return damper;
}

}  // namespace mrd::hil
