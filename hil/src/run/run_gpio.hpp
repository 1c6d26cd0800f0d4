#pragma once
// `mrd-hil run` with a scenario's [gpio] lines (scenario.hpp ScenarioGpio) next to the CAN
// bus: the plant side of the encoder, fault, enable and heartbeat lines on the simulated chip
// file (build machine) or a kernel gpio-sim chip (RunOptions::gpio_sim; the virtual board).
//
// Lockstep: the edges of step k must be in the firmware's count when it ticks on the grant of
// step k. The firmware holds edges younger than its horizon (GpioDevice::kEdgeHorizonNs,
// 200 us of CLOCK_MONOTONIC) to the next period, so after writing edges Publish waits until
// the newest is older than the settle time below before the grant goes out. The fault line is
// a level the firmware reads in its tick: no wait.

#include <cstdint>
#include <memory>
#include <string>

#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/hil/run/run.hpp"

namespace mrd::hil {

// After the last edge written, before the grant [ns]: above the firmware's 200 us horizon.
// On gpio-sim the kernel stamps an edge in its interrupt handler, a little after the write
// returns (longer under emulation): more margin.
inline constexpr std::int64_t kEdgeSettleSimChipNs = 250'000;
inline constexpr std::int64_t kEdgeSettleGpioSimNs = 1'000'000;

class RunGpio {
 public:
  // Opens the scenario's GPIO side (nothing without [gpio]); *firmware_chip: the firmware's
  // [gpio] chip (a simulated chip path, or the gpio-sim chip's name). false: *error.
  bool Open(const Scenario& s, const RunOptions& o, std::string* firmware_chip, std::string* error);
  bool active() const { return port_ != nullptr; }
  // Step k's encoder position and fault line; lockstep: returns once the edges are settled.
  void Publish(const SensorOutput& out, bool lockstep);
  // Enable and heartbeat as the firmware drives them.
  void Poll(DriverInput* in);
  void Close();
  const char* name() const { return port_ != nullptr ? port_->name() : "gpio"; }
  PortCounters counters() const { return port_ != nullptr ? port_->counters() : PortCounters{}; }

 private:
  std::unique_ptr<PlantPort> port_;
  std::int64_t settle_ns_ = kEdgeSettleSimChipNs;
  bool encoder_ = false;  // the scenario routes the displacement over the encoder lines
};

}  // namespace mrd::hil
