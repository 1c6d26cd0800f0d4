// The scenario file's top level and its [[fault]] tables (scenario_reader.hpp).
#include "scenario_reader.hpp"

namespace mrd::hil::scenario_reader {
namespace {

bool ParseFaultKind(const std::string& s, FaultKind* k) {
  static const std::map<std::string, FaultKind> kinds = {
      {"drop", FaultKind::kDrop},
      {"delay", FaultKind::kDelay},
      {"corrupt", FaultKind::kCorrupt},
      {"stall", FaultKind::kStall},
      {"out_of_range", FaultKind::kOutOfRange},
      {"nan", FaultKind::kNan},
      {"implausible", FaultKind::kImplausible},
      {"kill_plant", FaultKind::kKillPlant},
      {"kill_firmware", FaultKind::kKillFirmware},
      {"corrupt_table", FaultKind::kCorruptTable},
      {"fault_line", FaultKind::kFaultLine},
      {"drive_heartbeat_loss", FaultKind::kDriveHeartbeatLoss},
      {"driver_fault", FaultKind::kDriverFault},
      {"enable_refused", FaultKind::kEnableRefused}};
  const auto it = kinds.find(s);
  if (it == kinds.end()) return false;
  *k = it->second;
  return true;
}

}  // namespace

// Every key of the file into s (or the reader's own fields), then the checks in order.
bool ScenarioReader::Read() {
  if (!ReadKeys()) return false;
  s.heartbeat_timeout_s = hb_ms_ * 1e-3;
  return CheckPlantFiles() && CheckStructure() && CheckNarx() && CheckQuarterCar() &&
         CheckFullCar() && CheckChannels() && CheckExcitation() && CheckControl() && CheckPass() &&
         CheckFaults();
}

// The keys of a [section]; false: not a section.
bool ScenarioReader::SectionKeys(const std::string& key, std::map<std::string, Setter>* keys) {
  if (key == "plant")
    *keys = PlantKeys();
  else if (key == "excitation")
    *keys = ExcitationKeys();
  else if (key == "control")
    *keys = ControlKeys();
  else if (key == "firmware")
    *keys = FirmwareKeys();
  else if (key == "pass")
    *keys = PassKeys();
  else if (key == "quarter_car")
    *keys = QuarterCarKeys();
  else if (key == "full_car")
    *keys = FullCarKeys();
  else if (key == "road")
    *keys = RoadKeys();
  else if (key == "gpio")
    *keys = GpioKeys();
  else if (key == "channels")
    *keys = ChannelsKeys();
  else if (key == "structure")
    *keys = StructureKeys();
  else
    return false;
  return true;
}

// The file's top level: scalars, sections, [[fault]].
bool ScenarioReader::ReadKeys() {
  Ctx& c = c_;
  for (const auto& [k, v] : root_) {
    const std::string key(k.str());
    bool ok = true;
    std::map<std::string, Setter> keys;
    if (key == "name") {
      ok = Str(&s.name, "name")(v, c);
    } else if (key == "description") {
      ok = Str(&s.description, "description")(v, c);
    } else if (key == "duration_s") {
      ok = Num(&s.duration_s, 0.001, 1e6, "duration_s")(v, c);
    } else if (key == "e_max") {
      ok = Num(&s.e_max, 0.0, 24.0, "e_max")(v, c);
    } else if (key == "heartbeat_timeout_ms") {
      ok = Num(&hb_ms_, 1.0, 1e4, "heartbeat_timeout_ms")(v, c);
    } else if (SectionKeys(key, &keys)) {
      const toml::table* t = v.as_table();
      if (t == nullptr) return c.Fail(v, "[" + key + "] must be a table");
      ok = ApplyTable(*t, keys, " in [" + key + "]", c);
    } else if (key == "fault") {
      ok = ReadFaults(v);
    } else if (v.is_table()) {
      return c.Fail(v, "unknown section [" + key + "]");
    } else {
      return c.Fail(v, "unknown key '" + key + "'");
    }
    if (!ok) return false;
  }
  return true;
}

// [[fault]] tables into s.faults (each with its line for later messages).
bool ScenarioReader::ReadFaults(const toml::node& v) {
  Ctx& c = c_;
  const toml::array* a = v.as_array();
  if (a == nullptr) return c.Fail(v, "'fault' must be an array of tables ([[fault]])");
  for (const toml::node& e : *a) {
    const toml::table* t = e.as_table();
    if (t == nullptr) return c.Fail(e, "each [[fault]] must be a table");
    Fault f;
    f.line = static_cast<int>(e.source().begin.line);
    std::string kind;
    const std::map<std::string, Setter> fk = {
        {"kind", Str(&kind, "kind")},
        {"at_s", Num(&f.at_s, 0.0, 1e6, "at_s")},
        {"duration_s", Num(&f.duration_s, 0.0, 1e6, "duration_s")},
        {"delay_periods", Int(&f.delay_periods, 1, 100000, "delay_periods")},
        {"corner", Int(&f.corner, 0, 3, "corner")}};
    if (!ApplyTable(*t, fk, " in [[fault]]", c)) return false;
    if (kind.empty()) return c.Fail(e, "[[fault]] needs 'kind'");
    if (!ParseFaultKind(kind, &f.kind)) {
      return c.Fail(e, "unknown fault kind '" + kind + "' (see mrd-hil --help)");
    }
    s.faults.push_back(f);
  }
  return true;
}

}  // namespace mrd::hil::scenario_reader
