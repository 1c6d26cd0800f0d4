#include "mrd/firmware/io/fieldbus_io.hpp"

namespace mrd::firmware {
namespace {

std::size_t Index(IoError e) {
  const auto i = static_cast<std::size_t>(e);
  return i < kNumIoErrors ? i : static_cast<std::size_t>(IoError::kSystem);
}

std::uint64_t Sum(const std::uint64_t (&counts)[kNumIoErrors]) {
  std::uint64_t n = 0;
  for (const std::uint64_t c : counts) n += c;
  return n;
}

}  // namespace

std::uint64_t DeviceFaults::read_periods() const { return Sum(read); }
std::uint64_t DeviceFaults::write_periods() const { return Sum(write); }

bool FieldbusIo::Add(BusDevice* device) {
  if (device == nullptr || count_ >= kMaxDevices) return false;
  devices_[count_++] = device;
  return true;
}

IoStatus FieldbusIo::Read(const IoTime& t, SensorFrame* frame) {
  ++reads_;
  frame->bus_faults |= write_bus_faults_;  // the buses whose write failed last period
  write_bus_faults_ = 0;
  bool any_data = false;
  bool any_fault = false;
  for (std::size_t i = 0; i < count_; ++i) {
    IoError why = IoError::kNone;
    const IoStatus s = devices_[i]->Read(t, frame, &why);
    if (s == IoStatus::kFault) {
      any_fault = true;
      frame->bus_faults |= Watchdog::Bit(devices_[i]->fault_cause());
      // A fault without a reason counts as "none".
      ++faults_[i].read[Index(why)];
      faults_[i].last_read = why;
      published_[i].Write(faults_[i]);
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
    if (devices_[i]->Write(t, cmd, &why) != IoStatus::kFault) continue;
    fault = true;
    if (devices_[i]->write_faults_are_bus_faults()) {
      write_bus_faults_ |= Watchdog::Bit(devices_[i]->fault_cause());
    }
    // Once per period (the first faulted write's reason); before any Read, every write.
    if (reads_ == 0 || write_fault_period_[i] != reads_) {
      ++faults_[i].write[Index(why)];
      write_fault_period_[i] = reads_;
    }
    faults_[i].last_write = why;
    published_[i].Write(faults_[i]);
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
