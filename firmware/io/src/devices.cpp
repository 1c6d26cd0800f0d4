#include "mrd/firmware/io/devices.hpp"

namespace mrd::firmware {

bool MakeDevices(const IoConfig& io, std::vector<std::unique_ptr<BusDevice>>* out,
                 std::string* error) {
  out->clear();
  auto add = [&](std::unique_ptr<BusDevice> d, const char* bus) {
    if (d == nullptr) {
      *error = std::string(bus) + ": bus driver not available in this build";
      return false;
    }
    out->push_back(std::move(d));
    return true;
  };
  if (io.can.enabled && !add(MakeCanDevice(io.can), "can")) return false;
  if (io.modbus.enabled && !add(MakeModbusDevice(io.modbus), "modbus")) return false;
  if (io.gpio.enabled && !add(MakeGpioDevice(io.gpio), "gpio")) return false;
  // Written after the other buses in each period (FieldbusIo's order); the CAN status frame
  // of a period goes out after all of them (Loop::Tick: Write, then PublishStatus).
  if (io.pwm.enabled && !add(MakePwmDevice(io.pwm), "pwm")) return false;
  return true;
}

}  // namespace mrd::firmware
