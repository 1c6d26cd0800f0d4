#include "run_gpio.hpp"

#include <ctime>

#include "mrd/common/clock.hpp"
#include "mrd/hil/ports/gpio_port.hpp"
#include "mrd/hil/ports/gpio_sim_port.hpp"

namespace mrd::hil {
namespace {}  // namespace

bool RunGpio::Open(const Scenario& s, const RunOptions& o, std::string* firmware_chip,
                   std::string* error) {
  if (!s.gpio.any()) return true;
  encoder_ = s.gpio.displacement;
  GpioPortConfig c;
  c.counts_per_cm = s.gpio.counts_per_cm;
  if (o.gpio_sim.empty()) {
    c.path = o.work_dir + "/gpio.chip";
    port_ = MakeGpioPort(c);
    settle_ns_ = kEdgeSettleSimChipNs;
    *firmware_chip = c.path;
  } else {
    c.path = o.gpio_sim;
    if (!GpioSimChipName(o.gpio_sim, firmware_chip, error)) return false;
    port_ = MakeGpioSimPort(c);
    settle_ns_ = kEdgeSettleGpioSimNs;
  }
  if (!port_->Open(error)) {
    port_.reset();
    return false;
  }
  return true;
}

void RunGpio::Publish(const SensorOutput& out, bool lockstep) {
  if (port_ == nullptr) return;
  const std::uint64_t before = port_->counters().published;
  port_->Publish(out);
  // Without the encoder routed the firmware counts no edges: nothing to settle.
  if (!lockstep || !encoder_ || port_->counters().published == before) return;
  (void)common::SleepUntilNs(common::MonotonicNs() + settle_ns_);
}

void RunGpio::Poll(DriverInput* in) {
  if (port_ != nullptr) port_->Poll(in);
}

void RunGpio::Close() {
  if (port_ != nullptr) port_->Close();
}

}  // namespace mrd::hil
