#pragma once
// Fault-injection fakes for the firmware tests: a sensor source wrapper that corrupts, stalls
// or fails chosen reads, and a driver wrapper that fails chosen writes.

#include <cstdint>
#include <limits>

#include "mrd/firmware/io.hpp"

namespace mrd::test {

using firmware::CurrentDriver;
using firmware::IoStatus;
using firmware::SensorFrame;
using firmware::SensorSource;

// Reads through to `inner`, except in read-number windows [from, to) (0-based):
// NaN velocity, frozen stamps (stale), bus fault, fault line, velocity and displacement
// replaced by a spike value (an implausible reading).
class FaultySource final : public SensorSource {
 public:
  struct Window {
    std::uint64_t from = 0, to = 0;
    bool contains(std::uint64_t n) const { return n >= from && n < to; }
  };
  explicit FaultySource(SensorSource& inner) : inner_(inner) {}
  Window nan_velocity, stall, bus_fault, fault_line, spike;
  double spike_velocity = 500.0;     // [cm/s]
  double spike_displacement = 50.0;  // [cm]

  IoStatus Read(const firmware::IoTime& t, SensorFrame* frame) override {
    const std::uint64_t n = reads_++;
    IoStatus s = inner_.Read(t, frame);
    if (stall.contains(n)) {
      *frame = frozen_;
    } else {
      frozen_ = *frame;
    }
    if (nan_velocity.contains(n)) {
      (*frame)[firmware::Input::kVelocity].value = std::numeric_limits<double>::quiet_NaN();
    }
    if (fault_line.contains(n)) frame->fault_line = true;
    if (spike.contains(n)) {
      (*frame)[firmware::Input::kVelocity].value = spike_velocity;
      (*frame)[firmware::Input::kDisplacement].value = spike_displacement;
    }
    if (bus_fault.contains(n)) s = IoStatus::kFault;
    return s;
  }

 private:
  SensorSource& inner_;
  SensorFrame frozen_;
  std::uint64_t reads_ = 0;
};

class FaultyDriver final : public CurrentDriver {
 public:
  explicit FaultyDriver(CurrentDriver& inner) : inner_(inner) {}
  std::uint64_t fail_from = std::numeric_limits<std::uint64_t>::max(), fail_to = 0;
  std::uint64_t safe_calls = 0;
  double last_volts = -1.0;

  IoStatus Command(const firmware::IoTime& t, double volts) override {
    const std::uint64_t n = calls_++;
    last_volts = volts;
    if (n >= fail_from && n < fail_to) return IoStatus::kFault;
    return inner_.Command(t, volts);
  }
  IoStatus EnterSafeState(const firmware::IoTime& t, double volts) override {
    ++calls_;
    ++safe_calls;
    last_volts = volts;
    return inner_.EnterSafeState(t, volts);
  }

 private:
  CurrentDriver& inner_;
  std::uint64_t calls_ = 0;
};

}  // namespace mrd::test
