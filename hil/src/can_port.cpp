// Placeholder until the can device side lands.
#include "mrd/hil/plant_port.hpp"

namespace mrd::hil {

std::unique_ptr<PlantPort> MakeCanPort(const std::string& endpoint) {
  (void)endpoint;
  return nullptr;
}

}  // namespace mrd::hil
