#include "mrd/firmware/fieldbus_io.hpp"

namespace mrd::firmware {

bool FieldbusIo::Add(BusDevice* device) {
  if (device == nullptr || count_ >= kMaxDevices) return false;
  devices_[count_++] = device;
  return true;
}

IoStatus FieldbusIo::Read(const IoTime& t, SensorFrame* frame) {
  bool any_data = false;
  bool any_fault = false;
  for (std::size_t i = 0; i < count_; ++i) {
    IoError why = IoError::kNone;
    const IoStatus s = devices_[i]->Read(t, frame, &why);
    if (s == IoStatus::kFault) {
      any_fault = true;
      frame->bus_faults |= Watchdog::Bit(devices_[i]->fault_cause());
    } else if (s == IoStatus::kOk) {
      any_data = true;
    }
  }
  if (any_fault) return IoStatus::kFault;
  return any_data ? IoStatus::kOk : IoStatus::kNoData;
}

IoStatus FieldbusIo::Write(const IoTime& t, const DriverCommand& cmd) {
  bool fault = false;
  for (std::size_t i = 0; i < count_; ++i) {
    IoError why = IoError::kNone;
    if (devices_[i]->Write(t, cmd, &why) == IoStatus::kFault) fault = true;
  }
  return fault ? IoStatus::kFault : IoStatus::kOk;
}

IoStatus FieldbusIo::Command(const IoTime& t, double volts) {
  return Write(t, {volts, /*enable=*/true, /*safe=*/false, tick_++});
}

IoStatus FieldbusIo::EnterSafeState(const IoTime& t, double safe_volts) {
  return Write(t, {safe_volts, /*enable=*/false, /*safe=*/true, tick_++});
}

void FieldbusIo::PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) {
  for (std::size_t i = 0; i < count_; ++i) devices_[i]->PublishStatus(t, stats);
}

}  // namespace mrd::firmware
