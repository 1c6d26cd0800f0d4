#pragma once
// The loop's SensorSource and CurrentDriver over a set of field devices (bus_device.hpp).
//
//   Read:  each device merges its routed inputs into the frame; a device that faults sets its
//          bus's watchdog bit in frame.bus_faults (the other devices' samples still count).
//   Write: Command(V) sends {V, enable on} to every device; EnterSafeState(V) sends {V, enable
//          off}: 0 V on the bus and the enable line low. A device that fails a write makes the
//          whole write a fault (the loop then commands the safe state on all of them: the
//          watchdog's driver_fault); on Modbus and PWM it sets the bus's bit in the next Read's
//          frame.bus_faults too (a Modbus write answered with an exception is modbus_bus, as a
//          failed read is; BusDevice::write_faults_are_bus_faults).
//   Faults: per device, the periods whose read faulted and those with a faulted write, counted
//          per reason (IoError), and the reason of the last one of each (DeviceFaults),
//          published each period for other threads (faults(i)).
// Real-time safe: no allocation, the devices do bounded, non-blocking work.

#include <array>
#include <cstddef>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/seqlock.hpp"

namespace mrd::firmware {

// The faulted periods of one device, per reason (index: IoError). A period counts once per
// side: a failed command and the safe-state write that follows it in the same period count as
// one write period (the first one's reason); a shutdown write counts with the last period.
struct DeviceFaults {
  std::uint64_t read[kNumIoErrors] = {};   // periods whose Read faulted, per reason
  std::uint64_t write[kNumIoErrors] = {};  // periods with a faulted Write, per reason
  IoError last_read = IoError::kNone;      // reason of the last faulted read period
  IoError last_write = IoError::kNone;     // reason of the last faulted write
  std::uint64_t read_periods() const;      // sum of read[]
  std::uint64_t write_periods() const;     // sum of write[]
};

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
  // Device i's faulted periods (a copy; any thread). i < size().
  DeviceFaults faults(std::size_t i) const { return published_[i].Read(); }

 private:
  IoStatus Write(const IoTime& t, const DriverCommand& cmd);

  std::array<BusDevice*, kMaxDevices> devices_{};
  std::size_t count_ = 0;
  std::uint64_t tick_ = 0;
  std::uint64_t reads_ = 0;  // Read calls (periods) so far
  // Per device (tick thread): the counts, the period (reads_) of the last counted write fault.
  std::array<DeviceFaults, kMaxDevices> faults_{};
  std::array<std::uint64_t, kMaxDevices> write_fault_period_{};
  std::uint32_t write_bus_faults_ = 0;  // bus bits of failed writes, for the next Read
  std::array<Seqlock<DeviceFaults>, kMaxDevices> published_{};
};

}  // namespace mrd::firmware
