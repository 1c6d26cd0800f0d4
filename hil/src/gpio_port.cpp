// Placeholder until the gpio device side lands.
#include "mrd/hil/plant_port.hpp"

namespace mrd::hil {

std::unique_ptr<PlantPort> MakeGpioPort(const std::string& endpoint) {
  (void)endpoint;
  return nullptr;
}

}  // namespace mrd::hil
