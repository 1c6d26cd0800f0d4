#pragma once
// The harness's GPIO side on the kernel's gpio-sim driver (Linux >= 5.17, CONFIG_GPIO_SIM;
// Documentation/admin-guide/gpio/gpio-sim.rst): the firmware requests the chip's lines through
// libgpiod like a board's, and the plant plays the outside world through sysfs. Per line N
// the device has /sys/devices/platform/<dev_name>/<chip_name>/sim_gpioN/
//   pull   "pull-up" / "pull-down": the level an input line reads (an edge event when the
//          firmware watches it)
//   value  the level the chip holds (an output: the level the firmware drives)
// Endpoint: the configfs directory of a live gpio-sim device (e.g.
// /sys/kernel/config/gpio-sim/vboard) whose bank0 has at least 19 lines; its bank0/chip_name
// and dev_name locate the chip. Lines and encoder as GpioPortConfig (gpio_port.hpp); the
// encoder walks its count one quadrature step (one pull write) at a time, at most
// kMaxStepsPerPublish per step. Each write raises the edge interrupt at once; the kernel stamps
// the edge in its handler.

#include <memory>
#include <string>

#include "mrd/hil/ports/gpio_port.hpp"
#include "mrd/hil/ports/plant_port.hpp"

namespace mrd::hil {

// config.path: the configfs device directory. The chip's name for libgpiod (bank0's
// chip_name, e.g. "gpiochip0") once opened: GpioSimChipName.
std::unique_ptr<PlantPort> MakeGpioSimPort(const GpioPortConfig& config);

// bank0/chip_name of a live gpio-sim device (configfs dir); false with *error.
bool GpioSimChipName(const std::string& configfs_dir, std::string* name, std::string* error);

}  // namespace mrd::hil
