#pragma once
// ModbusDevice's wake-up policy for its link's waits (shared by modbus_device.cpp and
// modbus_device_profile.cpp).
#include "modbus_link.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"

namespace mrd::firmware {

// The link's wake-up policy. TCP is full duplex (a late reply is told by its transaction id):
// a stop abandons any wait, a safe block posted after a driven one was written abandons the
// request in flight. RTU is half duplex: nothing may be sent while a reply can be on its way,
// so only the quiet-line wait gives way (to both); a request in flight runs to its reply or
// its deadline.
class ModbusDevice::Waker final : public ModbusLink::Interrupt {
 public:
  explicit Waker(ModbusDevice& d) : d_(d) {}
  bool Abandon(ModbusLink::Phase phase) override {
    const bool tcp = d_.config_.mode == ModbusMode::kTcp;
    if (!d_.running_.load(std::memory_order_relaxed)) {
      return tcp || phase == ModbusLink::Phase::kQuiet;
    }
    if (d_.config_.lockstep || d_.writing_safe_ || !d_.SafePending()) return false;
    return tcp ? phase == ModbusLink::Phase::kReply : phase == ModbusLink::Phase::kQuiet;
  }

 private:
  ModbusDevice& d_;
};

}  // namespace mrd::firmware
