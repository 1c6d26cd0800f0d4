#pragma once
// The compiled-in table is a demonstration: a model of the reference (Spencer) damper, not of
// the user's. The firmware refuses to drive a real device with it (a SocketCAN interface, a
// GPIO chip, a Modbus device that is not the local simulation) unless told otherwise
// (--allow-demo-table); simulated endpoints (the local CAN bus, a simulated GPIO chip, Modbus
// on the loopback or a pseudo-terminal) take it, so the harness and bench runs work as before.

#include <string>

#include "mrd/common/table.hpp"
#include "mrd/firmware/io/io_config.hpp"

namespace mrd::firmware {

// True when `table` encodes to the same image as the compiled-in table.
bool IsDemoTable(const mrd::CoefficientTable& table);

// The first real device endpoint of `io` ("CAN interface can0", ...), or "" when every bus
// section talks to a simulation.
std::string RealDeviceOf(const IoConfig& io);

}  // namespace mrd::firmware
