#include "check.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "mrd/common/input_file.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/firmware/platform/safe_state.hpp"
#include "mrd/firmware/platform/table_update.hpp"

namespace mrd::firmware {
namespace {

using platform::CheckTable;
using platform::CheckTableOrRollBack;
using platform::FirmwareConfig;
using platform::InstallTable;
using platform::LoadConfigFile;
using platform::SafeStateProof;

constexpr int kOk = 0;
constexpr int kBadInput = 2;
// Where the package installs the device-profile guide (docs/devices.md in the source).
constexpr const char* kDevicesDoc = "/usr/share/doc/mrd-firmware/devices.md";

constexpr const char* kUsage =
    "usage: mrd-firmware --check-config FILE.toml\n"
    "       mrd-firmware --check-table FILE [--config FILE.toml] [--rollback]\n"
    "       mrd-firmware --install-table NEW --to DEST [--config FILE.toml]\n";

// reason may echo arguments and paths: printed as mrd::Printable (control bytes as \xNN).
int Refuse(const std::string& reason, bool usage = false) {
  std::fprintf(stderr, "error: %s\n%s", Printable(reason, 4 * kMaxEchoChars).c_str(),
               usage ? kUsage : "");
  return kBadInput;
}

}  // namespace

int RunMaintenance(int argc, char** argv) {
  if (argc < 2) return -1;
  const std::string command = argv[1];
  if (command != "--check-config" && command != "--check-table" && command != "--install-table") {
    return -1;
  }
  if (argc < 3) return Refuse(command + " needs a file", true);
  const char* file = argv[2];
  const char* config_path = command == "--check-config" ? file : nullptr;
  const char* to = nullptr;
  bool rollback = false;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--config" && command != "--check-config" && i + 1 < argc) {
      config_path = argv[++i];
    } else if (a == "--to" && command == "--install-table" && i + 1 < argc) {
      to = argv[++i];
    } else if (a == "--rollback" && command == "--check-table") {
      rollback = true;
    } else {
      return Refuse("unexpected argument '" + a + "' for " + command, true);
    }
  }
  FirmwareConfig config;
  if (config_path != nullptr) {
    std::string error;
    if (!LoadConfigFile(config_path, &config, &error)) return Refuse(error);
  }
  if (command == "--check-config") {
    // The service runs only with a bus to drive; a config without one is for --dry-run.
    if (!config.io.any()) {
      return Refuse(std::string(file) +
                    ": no device profile configured: no [can], [modbus] or [gpio] section, so "
                    "the firmware has nothing to drive (it would only run --dry-run). Say how "
                    "your driver and sensors are wired: see " +
                    std::string(kDevicesDoc));
    }
    std::printf("config %s: ok\n", file);
    // What the wire carries in the safe state (proved by the load; E_max: the configuration's,
    // else the compiled-in table's).
    const SafeStateProof proof = ProveSafeState(config, config.e_max.value_or(kBuiltinTable.e_max));
    for (const std::string& line : proof.lines) std::printf("  safe state: %s\n", line.c_str());
    return kOk;
  }
  if (command == "--install-table") {
    if (to == nullptr) return Refuse("--install-table needs --to DEST", true);
    const bool had_one = access(to, F_OK) == 0;  // a table to keep as DEST.prev
    const std::string why = InstallTable(file, to, config);
    if (!why.empty()) return Refuse(why + " (nothing installed)");
    if (had_one) {
      std::printf("table %s installed as %s (previous kept as %s.prev)\n", file, to, to);
    } else {
      std::printf("table %s installed as %s (no previous table)\n", file, to);
    }
    return kOk;
  }
  if (!rollback) {
    const std::string why = CheckTable(file, config);
    if (!why.empty()) return Refuse(why);
    std::printf("table %s: ok\n", file);
    return kOk;
  }
  bool rolled_back = false;
  const std::string why = CheckTableOrRollBack(file, config, &rolled_back);
  if (!why.empty()) return Refuse(why);
  if (rolled_back) {
    std::fprintf(stderr,
                 "warning: table %s was refused; rolled back to the previous table (refused one "
                 "kept as %s.refused)\n",
                 file, file);
  }
  std::printf("table %s: ok%s\n", file, rolled_back ? " (rolled back)" : "");
  return kOk;
}

}  // namespace mrd::firmware
