// FieldbusIo keeps why each device faulted: per device, the faulted read and write periods
// per reason (IoError) and the last reason of each (DeviceFaults), real-time safe.
// Labels fieldbus, unit.
#include <gtest/gtest.h>

#include <cstddef>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/loop.hpp"
#include "support/alloc_counter.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;

std::uint64_t At(const std::uint64_t (&counts)[kNumIoErrors], IoError e) {
  return counts[static_cast<std::size_t>(e)];
}

// Serves a fresh velocity and demand each read; faults with the reason it is given.
class FaultingDevice final : public BusDevice {
 public:
  FaultingDevice(const char* name, FaultCause cause) : name_(name), cause_(cause) {}
  const char* name() const override { return name_; }
  FaultCause fault_cause() const override { return cause_; }
  bool Configure(std::string*) override { return true; }
  bool Activate(std::string*) override { return true; }
  void Deactivate() override {}
  IoStatus Read(const IoTime& t, SensorFrame* frame, IoError* why) override {
    if (read_fault != IoError::kNone) {
      *why = read_fault;
      return IoStatus::kFault;
    }
    (*frame)[Input::kVelocity] = {1.0, t.loop_ns};
    (*frame)[Input::kDemand] = {100.0, t.loop_ns};
    return IoStatus::kOk;
  }
  IoStatus Write(const IoTime&, const DriverCommand&, IoError* why) override {
    if (write_fault != IoError::kNone) {
      *why = write_fault;
      return IoStatus::kFault;
    }
    return IoStatus::kOk;
  }
  DeviceCounters counters() const override { return {}; }

  IoError read_fault = IoError::kNone, write_fault = IoError::kNone;

 private:
  const char* name_;
  FaultCause cause_;
};

IoTime At(std::int64_t t) { return {t, t}; }

TEST(FieldbusIoFaultsTest, CountsReadFaultsPerDeviceAndReason) {
  FaultingDevice can("can", FaultCause::kCanBus), modbus("modbus", FaultCause::kModbusBus);
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&can));
  ASSERT_TRUE(io.Add(&modbus));
  SensorFrame frame;
  EXPECT_EQ(io.Read(At(1), &frame), IoStatus::kOk);
  modbus.read_fault = IoError::kTimeout;
  for (int k = 0; k < 3; ++k) EXPECT_EQ(io.Read(At(2 + k), &frame), IoStatus::kFault);
  modbus.read_fault = IoError::kCrc;
  EXPECT_EQ(io.Read(At(5), &frame), IoStatus::kFault);
  modbus.read_fault = IoError::kNone;
  EXPECT_EQ(io.Read(At(6), &frame), IoStatus::kOk);  // recovered: the last reason stays

  const DeviceFaults m = io.faults(1);
  EXPECT_EQ(At(m.read, IoError::kTimeout), 3U);
  EXPECT_EQ(At(m.read, IoError::kCrc), 1U);
  EXPECT_EQ(m.read_periods(), 4U);
  EXPECT_EQ(m.last_read, IoError::kCrc);
  EXPECT_EQ(m.write_periods(), 0U);
  EXPECT_EQ(m.last_write, IoError::kNone);
  const DeviceFaults c = io.faults(0);  // the healthy device: nothing
  EXPECT_EQ(c.read_periods(), 0U);
  EXPECT_EQ(c.last_read, IoError::kNone);
}

TEST(FieldbusIoFaultsTest, AFaultWithoutAReasonCountsAsNone) {
  FaultingDevice gpio("gpio", FaultCause::kGpioBus);
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&gpio));
  // A device that reports a fault but leaves *why alone: FieldbusIo's kNone stands.
  class Silent final : public BusDevice {
   public:
    const char* name() const override { return "silent"; }
    FaultCause fault_cause() const override { return FaultCause::kGpioBus; }
    bool Configure(std::string*) override { return true; }
    bool Activate(std::string*) override { return true; }
    void Deactivate() override {}
    IoStatus Read(const IoTime&, SensorFrame*, IoError*) override { return IoStatus::kFault; }
    IoStatus Write(const IoTime&, const DriverCommand&, IoError*) override {
      return IoStatus::kFault;
    }
    DeviceCounters counters() const override { return {}; }
  } silent;
  ASSERT_TRUE(io.Add(&silent));
  SensorFrame frame;
  EXPECT_EQ(io.Read(At(1), &frame), IoStatus::kFault);
  EXPECT_EQ(io.Command(At(1), 1.0), IoStatus::kFault);
  const DeviceFaults f = io.faults(1);
  EXPECT_EQ(At(f.read, IoError::kNone), 1U);
  EXPECT_EQ(At(f.write, IoError::kNone), 1U);
  EXPECT_EQ(io.faults(0).read_periods(), 0U);
}

// In the loop: a failed command and the safe-state write that follows it in the same period
// are one faulted write period; each period counts once per side.
TEST(FieldbusIoFaultsTest, LoopPeriodsCountOncePerSide) {
  FaultingDevice can("can", FaultCause::kCanBus);
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&can));
  Controller controller;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk);
  Telemetry telemetry;
  LockstepClock clock;
  Loop loop(clock, io, io, controller, telemetry, kPeriod);
  std::int64_t t = 0;
  for (int k = 0; k < 20; ++k) loop.Tick(At(t += kPeriod));  // healthy
  can.write_fault = IoError::kOverflow;
  test::AllocationGuard guard;
  for (int k = 0; k < 7; ++k) loop.Tick(At(t += kPeriod));
  can.write_fault = IoError::kNone;
  can.read_fault = IoError::kDisconnected;
  for (int k = 0; k < 4; ++k) loop.Tick(At(t += kPeriod));
  EXPECT_EQ(guard.count(), 0U);  // the tick path records without allocating
  const DeviceFaults f = io.faults(0);
  EXPECT_EQ(At(f.write, IoError::kOverflow), 7U);
  EXPECT_EQ(f.write_periods(), 7U);
  EXPECT_EQ(f.last_write, IoError::kOverflow);
  EXPECT_EQ(At(f.read, IoError::kDisconnected), 4U);
  EXPECT_EQ(f.last_read, IoError::kDisconnected);
  // The loop's own counters agree: one write fault per faulted period.
  EXPECT_EQ(loop.stats().write_faults, 7U);
  EXPECT_EQ(loop.stats().read_faults, 4U);
}

}  // namespace
}  // namespace mrd::firmware
