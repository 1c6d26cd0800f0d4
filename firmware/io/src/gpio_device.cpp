// Placeholder until the gpio driver lands: the factory reports the bus as unavailable.
#include "mrd/firmware/io/devices.hpp"

namespace mrd::firmware {

std::unique_ptr<BusDevice> MakeGpioDevice(const GpioConfig& config) {
  (void)config;
  return nullptr;
}

}  // namespace mrd::firmware
