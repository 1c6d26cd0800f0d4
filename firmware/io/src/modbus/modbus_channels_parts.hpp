#pragma once
// ModbusChannels' private parts shared by its sources: the channel view and the wake-up policy.
//
// The wake-up policy for its link's waits: the one-channel device's
// (modbus_waker.hpp) over every channel: a stop abandons any TCP wait and the RTU quiet-line
// wait; outside lockstep, a safe block any channel posted after a driven one abandons the
// reply wait (TCP) or the quiet-line wait (RTU).
#include "modbus_link.hpp"
#include "mrd/firmware/io/modbus/modbus_channels.hpp"
#include "mrd/firmware/telemetry.hpp"

namespace mrd::firmware {

class ModbusChannels::Waker final : public ModbusLink::Interrupt {
 public:
  explicit Waker(ModbusChannels& d) : d_(d) {}
  bool Abandon(ModbusLink::Phase phase) override {
    const bool tcp = d_.config_.mode == ModbusMode::kTcp;
    if (!d_.running_.load(std::memory_order_relaxed)) {
      return tcp || phase == ModbusLink::Phase::kQuiet;
    }
    if (d_.config_.lockstep || d_.writing_safe_ || !d_.SafePending()) return false;
    return tcp ? phase == ModbusLink::Phase::kReply : phase == ModbusLink::Phase::kQuiet;
  }

 private:
  ModbusChannels& d_;
};

// Channel k as the loop sees it: a BusDevice over the shared link.
class ModbusChannels::View final : public BusDevice {
 public:
  View(ModbusChannels& d, std::size_t k) : d_(d), k_(k) {}
  const char* name() const override { return "modbus"; }
  FaultCause fault_cause() const override { return FaultCause::kModbusBus; }
  bool write_faults_are_bus_faults() const override { return true; }
  bool Configure(std::string* error) override { return d_.Configure(error); }
  bool Activate(std::string* error) override {
    if (active_) return true;
    active_ = d_.Activate(error);
    return active_;
  }
  void Deactivate() override {
    if (!active_) return;
    active_ = false;
    d_.Deactivate();
  }
  IoStatus Read(const IoTime& t, SensorFrame* frame, IoError* why) override {
    (void)t;
    return d_.Read(k_, frame, why);
  }
  IoStatus Write(const IoTime& t, const DriverCommand& cmd, IoError* why) override {
    return d_.Write(k_, t, cmd, why);
  }
  void PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) override {
    (void)t;
    d_.PublishStatus(k_, stats);
  }
  DeviceCounters counters() const override { return d_.counters(k_); }
  TimeGrantSource* grant_source() override {
    return k_ == 0 && d_.config_.lockstep ? &d_ : nullptr;
  }

 private:
  ModbusChannels& d_;
  const std::size_t k_;
  bool active_ = false;  // Activate succeeded, Deactivate not yet called
};

}  // namespace mrd::firmware
