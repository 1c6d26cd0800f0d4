#include "table_check.hpp"

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <vector>

#include "mrd/common/input_file.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/platform/table_file.hpp"
#include "mrd/hil/plants/model_plant.hpp"

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
  const auto loaded = firmware::platform::LoadTableFile(path.c_str(), &reason);
  if (loaded.ok()) {
    *table = loaded.value();
    return true;
  }
  std::fprintf(stderr, "error: %s: %s\n", Printable(path).c_str(), reason.c_str());
  return false;
}

std::string TableLabel(const std::string& path, const CoefficientTable& table) {
  // A file's own CRC (its last 4 bytes in every version: an older-version file is named as
  // `crc32` names it, not as re-encoded); the compiled-in table's image.
  std::vector<std::uint8_t> b;
  std::size_t at = 0;
  if (!path.empty()) {
    std::ifstream in(path, std::ios::binary);
    b.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    at = b.size() >= 4 ? b.size() - 4 : b.size();
  } else if (const auto image = EncodeTable(table); image.ok()) {
    b.assign(image.value().begin(), image.value().end());
    at = kTableCrcOffset;
  }
  char crc[32] = "CRC-32 n/a";
  if (at + 4 <= b.size()) {
    const std::uint32_t v =
        static_cast<std::uint32_t>(b[at]) | static_cast<std::uint32_t>(b[at + 1]) << 8 |
        static_cast<std::uint32_t>(b[at + 2]) << 16 | static_cast<std::uint32_t>(b[at + 3]) << 24;
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
  if (s.full_car) return "full car (four corners), " + damper;
  if (s.structure) return "three-story structure, " + damper;
  return damper;
}

}  // namespace mrd::hil
