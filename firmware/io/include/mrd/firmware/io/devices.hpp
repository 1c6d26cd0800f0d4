#pragma once
// Builds the field devices a configuration routes signals to (io_config.hpp). Start-up only.

#include <memory>
#include <string>
#include <vector>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/io/io_config.hpp"

namespace mrd::firmware {

// One device per enabled bus section, not yet configured. false with *error when a bus is
// not available in this build.
bool MakeDevices(const IoConfig& io, std::vector<std::unique_ptr<BusDevice>>* out,
                 std::string* error);

// Per bus (can_device.cpp, modbus_device.cpp, gpio_device.cpp, pwm_device.cpp).
std::unique_ptr<BusDevice> MakeCanDevice(const CanConfig& config);
std::unique_ptr<BusDevice> MakeModbusDevice(const ModbusConfig& config);
std::unique_ptr<BusDevice> MakeGpioDevice(const GpioConfig& config);
// nullptr without a loaded profile (pwm_device.cpp).
std::unique_ptr<BusDevice> MakePwmDevice(const PwmOutputConfig& config);

}  // namespace mrd::firmware
