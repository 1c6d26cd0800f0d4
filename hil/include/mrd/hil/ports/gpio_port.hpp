#pragma once
// The harness's GPIO side (plant_port.hpp) on a simulated chip (mrd/sim_gpio/sim_chip.hpp):
// it creates the chip, drives the quadrature encoder lines from the plant's displacement and
// the fault line from the serve loop's fault window, and reads the firmware's enable and
// heartbeat lines for the simulated current driver (enable low or a stalled heartbeat: coil
// at 0 V).
//
// Endpoint: "PATH[,KEY=VALUE...]". The defaults match firmware/examples/can-gpio.toml:
//   encoder_a=4 encoder_b=5 fault=6 enable=17 heartbeat=18 counts_per_cm=400
//   fault_active_low=0
// counts_per_cm must equal the firmware's [gpio] counts_per_cm (else the firmware's
// displacement is scaled wrong); the line offsets must match its *_line keys.
//
// Encoder: each step the target count is round(x * counts_per_cm); the port walks its count
// there one quadrature step (one edge on one line) at a time, each edge with its own
// CLOCK_MONOTONIC stamp, at most kMaxStepsPerPublish per step (a jump is spread over the
// following steps, so the chip's event rings never overflow). PortCounters::published counts
// the edges written, received the heartbeat toggles and enable changes heard.

#include <cstdint>
#include <memory>
#include <string>

#include "mrd/hil/ports/plant_port.hpp"

namespace mrd::hil {

struct GpioPortConfig {
  std::string path;  // simulated chip file (created when missing)
  int encoder_a_line = 4;
  int encoder_b_line = 5;
  int fault_line = 6;
  int enable_line = 17;
  int heartbeat_line = 18;
  bool fault_active_low = false;
  double counts_per_cm = 400.0;
};

inline constexpr int kMaxStepsPerPublish = 128;

// The encoder's move this step (both GPIO ports): from `count` toward round(x_cm *
// counts_per_cm), clamped to +-kMaxStepsPerPublish; 0 when the target is not finite or beyond
// +-9e15 counts (the port keeps its count).
std::int64_t EncoderStepsToward(double x_cm, double counts_per_cm, std::int64_t count);

// Parses "PATH[,KEY=VALUE...]". false with *error ("gpio endpoint 'E': reason") on an unknown
// key, a bad value, a line outside the chip or two functions on one line.
bool ParseGpioEndpoint(const std::string& endpoint, GpioPortConfig* out, std::string* error);

std::unique_ptr<PlantPort> MakeGpioPort(const GpioPortConfig& config);

}  // namespace mrd::hil
