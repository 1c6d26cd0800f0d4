// FieldbusIo: the loop's source and driver over several bus devices.
#include "mrd/firmware/io/fieldbus_io.hpp"

#include <gtest/gtest.h>

#include <optional>

#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/loop.hpp"
#include "support/demo_model.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

// A device that serves fixed samples, fails when told, and records what it was sent.
class FakeDevice final : public BusDevice {
 public:
  FakeDevice(const char* name, FaultCause cause) : name_(name), cause_(cause) {}
  const char* name() const override { return name_; }
  FaultCause fault_cause() const override { return cause_; }
  bool Configure(std::string*) override { return true; }
  bool Activate(std::string*) override { return true; }
  void Deactivate() override {}
  IoStatus Read(const IoTime&, SensorFrame* frame, IoError* why) override {
    if (fail_read) {
      *why = IoError::kTimeout;
      return IoStatus::kFault;
    }
    if (velocity) (*frame)[Input::kVelocity] = {*velocity, stamp};
    if (demand) (*frame)[Input::kDemand] = {*demand, stamp};
    return velocity || demand ? IoStatus::kOk : IoStatus::kNoData;
  }
  IoStatus Write(const IoTime&, const DriverCommand& cmd, IoError* why) override {
    last = cmd;
    ++writes;
    if (fail_write) {
      *why = IoError::kDisconnected;
      return IoStatus::kFault;
    }
    return IoStatus::kOk;
  }
  void PublishStatus(const IoTime&, const TelemetrySnapshot& s) override { status_ticks = s.ticks; }
  DeviceCounters counters() const override { return {}; }

  std::optional<double> velocity, demand;
  std::int64_t stamp = 0;
  bool fail_read = false, fail_write = false;
  DriverCommand last;
  int writes = 0;
  std::uint64_t status_ticks = 0;

 private:
  const char* name_;
  FaultCause cause_;
};

TEST(FieldbusIoTest, MergesTheInputsOfEveryDevice) {
  FakeDevice can("can", FaultCause::kCanBus), modbus("modbus", FaultCause::kModbusBus);
  can.velocity = 3.0;
  can.stamp = 10;
  modbus.demand = -200.0;
  modbus.stamp = 20;
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&can));
  ASSERT_TRUE(io.Add(&modbus));
  SensorFrame f;
  EXPECT_EQ(io.Read(::mrd::test::NowIo(), &f), IoStatus::kOk);
  EXPECT_EQ(f[Input::kVelocity].value, 3.0);
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, 10);
  EXPECT_EQ(f[Input::kDemand].value, -200.0);
  EXPECT_EQ(f[Input::kDemand].stamp_ns, 20);
  EXPECT_EQ(f.bus_faults, 0U);
}

TEST(FieldbusIoTest, AFaultedDeviceNamesItsBusAndKeepsTheOthersSamples) {
  FakeDevice can("can", FaultCause::kCanBus), gpio("gpio", FaultCause::kGpioBus);
  can.velocity = 1.5;
  gpio.fail_read = true;
  FieldbusIo io;
  io.Add(&can);
  io.Add(&gpio);
  SensorFrame f;
  EXPECT_EQ(io.Read(::mrd::test::NowIo(), &f), IoStatus::kFault);
  EXPECT_EQ(f.bus_faults, Watchdog::Bit(FaultCause::kGpioBus));
  EXPECT_EQ(f[Input::kVelocity].value, 1.5);
}

TEST(FieldbusIoTest, NoDataWhenNoDeviceHasAnything) {
  FakeDevice can("can", FaultCause::kCanBus);
  FieldbusIo io;
  io.Add(&can);
  SensorFrame f;
  EXPECT_EQ(io.Read(::mrd::test::NowIo(), &f), IoStatus::kNoData);
}

TEST(FieldbusIoTest, CommandEnablesAndSafeStateDisablesEveryDevice) {
  FakeDevice can("can", FaultCause::kCanBus), gpio("gpio", FaultCause::kGpioBus);
  FieldbusIo io;
  io.Add(&can);
  io.Add(&gpio);
  EXPECT_EQ(io.Command(::mrd::test::NowIo(), 1.25), IoStatus::kOk);
  EXPECT_EQ(can.last.volts, 1.25);
  EXPECT_TRUE(can.last.enable);
  EXPECT_FALSE(can.last.safe);
  EXPECT_TRUE(gpio.last.enable);
  EXPECT_EQ(io.EnterSafeState(::mrd::test::NowIo(), 0.0), IoStatus::kOk);
  EXPECT_EQ(can.last.volts, 0.0);
  EXPECT_FALSE(can.last.enable);
  EXPECT_TRUE(can.last.safe);
  EXPECT_FALSE(gpio.last.enable);
  EXPECT_EQ(gpio.last.tick, 1U);  // heartbeats count every write
}

TEST(FieldbusIoTest, AFailedWriteOnAnyDeviceIsAFaultButAllAreWritten) {
  FakeDevice can("can", FaultCause::kCanBus), gpio("gpio", FaultCause::kGpioBus);
  can.fail_write = true;
  FieldbusIo io;
  io.Add(&can);
  io.Add(&gpio);
  EXPECT_EQ(io.EnterSafeState(::mrd::test::NowIo(), 0.0), IoStatus::kFault);
  EXPECT_EQ(gpio.writes, 1);
  EXPECT_FALSE(gpio.last.enable);
}

TEST(FieldbusIoTest, RefusesMoreDevicesThanItHolds) {
  FakeDevice d("can", FaultCause::kCanBus);
  FieldbusIo io;
  for (std::size_t i = 0; i < FieldbusIo::kMaxDevices; ++i) EXPECT_TRUE(io.Add(&d));
  EXPECT_FALSE(io.Add(&d));
  EXPECT_FALSE(io.Add(nullptr));
}

// Through the loop: a bus fault trips that bus's watchdog cause (not the generic one), the
// driver gets the safe state with enable low, and the loop recovers when the bus does.
TEST(FieldbusIoTest, BusFaultTripsItsOwnCauseAndRecovers) {
  FakeDevice can("can", FaultCause::kCanBus);
  FieldbusIo io;
  io.Add(&can);
  LockstepClock clock;
  Controller controller;
  ControllerConfig cfg;
  cfg.law.mode = ControlMode::kConstantVoltage;
  cfg.law.constant_voltage = 1.0;
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), cfg), Error::kOk);
  Telemetry telemetry;
  constexpr std::int64_t kPeriod = 1'000'000;
  Loop loop(clock, io, io, controller, telemetry, kPeriod);
  auto tick = [&](int n) {
    for (int i = 0; i < n; ++i) {
      clock.Advance(kPeriod);
      can.stamp = clock.Now();
      loop.Tick(clock.Now());
    }
  };
  can.velocity = 2.0;
  tick(5);
  EXPECT_TRUE(can.last.enable);
  EXPECT_EQ(can.last.volts, 1.0);
  can.fail_read = true;
  tick(3);
  EXPECT_FALSE(can.last.enable);
  EXPECT_TRUE(can.last.safe);
  const auto& w = loop.stats().watchdog;
  EXPECT_EQ(w.trips[static_cast<std::size_t>(FaultCause::kCanBus)], 1U);
  EXPECT_EQ(w.active_periods[static_cast<std::size_t>(FaultCause::kCanBus)], 3U);
  EXPECT_EQ(w.trips[static_cast<std::size_t>(FaultCause::kBusFault)], 0U);
  can.fail_read = false;
  tick(3);
  EXPECT_TRUE(can.last.enable);
  EXPECT_EQ(can.status_ticks, loop.stats().ticks);
}

}  // namespace
}  // namespace mrd::firmware
