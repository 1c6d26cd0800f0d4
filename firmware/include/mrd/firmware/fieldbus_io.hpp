#pragma once
// The loop's SensorSource and CurrentDriver over a set of field devices (bus_device.hpp).
//
//   Read:  each device merges its routed inputs into the frame; a device that faults sets its
//          bus's watchdog bit in frame.bus_faults (the other devices' samples still count).
//   Write: Command(V) sends {V, enable on} to every device; EnterSafeState(V) sends {V, enable
//          off}: 0 V on the bus and the enable line low. A device that fails a write makes the
//          whole write a fault (the loop then commands the safe state on all of them).
// Real-time safe: no allocation, the devices do bounded, non-blocking work.

#include <array>
#include <cstddef>

#include "mrd/firmware/bus_device.hpp"

namespace mrd::firmware {

class FieldbusIo final : public SensorSource, public CurrentDriver {
 public:
  static constexpr std::size_t kMaxDevices = 4;

  // Devices are not owned and outlive this. false when more than kMaxDevices are added.
  bool Add(BusDevice* device);

  IoStatus Read(const IoTime& t, SensorFrame* frame) override;
  IoStatus Command(const IoTime& t, double volts) override;
  IoStatus EnterSafeState(const IoTime& t, double safe_volts) override;
  void PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) override;

  std::size_t size() const { return count_; }
  BusDevice* device(std::size_t i) const { return devices_[i]; }

 private:
  IoStatus Write(const IoTime& t, const DriverCommand& cmd);

  std::array<BusDevice*, kMaxDevices> devices_{};
  std::size_t count_ = 0;
  std::uint64_t tick_ = 0;
};

}  // namespace mrd::firmware
