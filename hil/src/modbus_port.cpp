// Placeholder until the modbus device side lands.
#include "mrd/hil/plant_port.hpp"

namespace mrd::hil {

std::unique_ptr<PlantPort> MakeModbusTcpPort(const std::string& endpoint) {
  (void)endpoint;
  return nullptr;
}

std::unique_ptr<PlantPort> MakeModbusRtuPort(const std::string& endpoint) {
  (void)endpoint;
  return nullptr;
}

}  // namespace mrd::hil
