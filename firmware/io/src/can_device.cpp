// Placeholder until the can driver lands: the factory reports the bus as unavailable.
#include "mrd/firmware/io/devices.hpp"

namespace mrd::firmware {

std::unique_ptr<BusDevice> MakeCanDevice(const CanConfig& config) {
  (void)config;
  return nullptr;
}

}  // namespace mrd::firmware
