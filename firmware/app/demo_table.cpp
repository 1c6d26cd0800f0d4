#include "demo_table.hpp"

#include <climits>
#include <cstdlib>

#include "mrd/firmware/builtin_table.hpp"

namespace mrd::firmware {

bool IsDemoTable(const mrd::CoefficientTable& table) {
  const auto image = mrd::EncodeTable(table);
  const auto demo = mrd::EncodeTable(kBuiltinTable);
  return image.ok() && demo.ok() && image.value() == demo.value();
}

namespace {

bool Loopback(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

// A pseudo-terminal (the harness's or a test's simulated serial line), through symlinks.
bool PseudoTerminal(const std::string& device) {
  char resolved[PATH_MAX];
  const std::string path = realpath(device.c_str(), resolved) != nullptr ? resolved : device;
  return path.rfind("/dev/pts/", 0) == 0;
}

}  // namespace

std::string RealDeviceOf(const IoConfig& io) {
  if (io.can.enabled && !io.can.interface.empty()) return "CAN interface " + io.can.interface;
  if (io.gpio.enabled && !io.gpio.chip.empty()) return "GPIO chip " + io.gpio.chip;
  if (io.modbus.enabled) {
    if (io.modbus.mode == ModbusMode::kTcp && !Loopback(io.modbus.host)) {
      return "Modbus TCP device " + io.modbus.host;
    }
    if (io.modbus.mode == ModbusMode::kRtu && !PseudoTerminal(io.modbus.device)) {
      return "Modbus RTU device " + io.modbus.device;
    }
  }
  return "";
}

}  // namespace mrd::firmware
