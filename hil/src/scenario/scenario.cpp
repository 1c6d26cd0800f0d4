// A HIL scenario from its TOML file (scenario.hpp); the reading: scenario_reader.hpp.
#include "mrd/hil/scenario/scenario.hpp"

#include <toml++/toml.h>

#include "mrd/common/input_file.hpp"
#include "scenario_reader.hpp"
#include "scenario_set.hpp"

namespace mrd::hil {
namespace {

constexpr std::uint64_t kMaxScenarioBytes = 1 << 20;  // [bytes]

}  // namespace

const char* FaultKindName(FaultKind kind) {
  switch (kind) {
    case FaultKind::kDrop:
      return "drop";
    case FaultKind::kDelay:
      return "delay";
    case FaultKind::kCorrupt:
      return "corrupt";
    case FaultKind::kStall:
      return "stall";
    case FaultKind::kOutOfRange:
      return "out_of_range";
    case FaultKind::kNan:
      return "nan";
    case FaultKind::kImplausible:
      return "implausible";
    case FaultKind::kKillPlant:
      return "kill_plant";
    case FaultKind::kKillFirmware:
      return "kill_firmware";
    case FaultKind::kCorruptTable:
      return "corrupt_table";
    case FaultKind::kFaultLine:
      return "fault_line";
    case FaultKind::kDriveHeartbeatLoss:
      return "drive_heartbeat_loss";
    case FaultKind::kDriverFault:
      return "driver_fault";
    case FaultKind::kEnableRefused:
      return "enable_refused";
  }
  return "?";
}

bool LoadScenario(const std::string& path, Scenario* scenario, std::string* error) {
  return LoadScenario(path, {}, scenario, error);
}

bool LoadScenario(const std::string& path, const std::vector<std::string>& sets, Scenario* scenario,
                  std::string* error) {
  try {
    // A regular file of at most kMaxScenarioBytes: a directory, FIFO or device is refused.
    std::string text;
    if (!ReadInputFile(path, kMaxScenarioBytes, &text, error)) return false;
    toml::table root = toml::parse(text, path);
    if (!ApplyScenarioSets(sets, &root, error)) return false;
    scenario_reader::ScenarioReader reader(path, &root, error);
    if (!reader.Read()) return false;
    *scenario = std::move(reader.s);
    return true;
  } catch (const toml::parse_error& e) {
    *error = Printable(path) + ":" + std::to_string(e.source().begin.line) + ": " +
             Printable(e.description());
    return false;
  } catch (const std::exception& e) {
    *error = Printable(path) + ": " + e.what();
    return false;
  }
}

bool IsChassisLaw(const std::string& law) {
  return law == "groundhook" || law == "groundhook-on-off" || law == "hybrid" || law == "add" ||
         law == "sh-add";
}

}  // namespace mrd::hil
