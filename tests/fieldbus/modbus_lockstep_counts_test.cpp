// In lockstep the Modbus device's request and sample counts depend on the steps alone, not on
// when its worker thread ran (the lockstep summaries compare them bit for bit):
// - a sensor block read before the first grant belongs to no step: not data, not counted;
// - the shutdown's safe block, posted after the last published tick, is written once, by
//   Deactivate after the worker stopped, never by the worker racing it.
// Over Modbus TCP with the built-in register map and with the modbus-float32 device profile,
// against the harness's own ports. The waits only give the worker the chance to go wrong;
// nothing is asserted on time.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "modbus_lockstep_setup.hpp"
#include "modbus_test_peers.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kMs = 1'000'000;  // [ns]
constexpr int kSteps = 3;
constexpr std::int64_t kTimeoutNs = 2000 * kMs;  // as mrd-hil writes it for lockstep

// Time for the worker (it polls every 20 us in lockstep) to do what it should not.
void GiveTheWorkerTime() { std::this_thread::sleep_for(std::chrono::milliseconds(300)); }

// kSteps lockstep periods as the harness and the loop run them, then the loop's shutdown;
// `shutdown_counted`: the port counts the safe block as a command (the register map's port
// counts a status tick once, and the safe block carries the last tick's).
void RunAndShutDown(hil::PlantPort& port, ModbusDevice& device, bool shutdown_counted) {
  std::string error;
  port.SetLockstep(true);
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  GiveTheWorkerTime();  // it reads the (empty) block before any grant
  EXPECT_EQ(device.counters().rx_ok, 0U) << "a block from before the first grant was data";

  std::uint64_t tick = 0;
  for (int k = 1; k <= kSteps; ++k) {
    hil::SensorOutput o;
    o.seq = static_cast<std::uint32_t>(k);
    o.sample.v = k;
    port.Publish(o);
    ASSERT_TRUE(port.SendGrant(k * kMs));
    std::int64_t t = 0;
    ASSERT_TRUE(device.WaitGrant(3000 * kMs, &t));
    ASSERT_EQ(t, k * kMs);
    ASSERT_TRUE(test::WaitFor([&] {
      SensorFrame f;
      IoError why = IoError::kNone;
      return device.Read(test::NowIo(), &f, &why) == IoStatus::kOk;
    })) << "step "
        << k;
    IoError why = IoError::kNone;
    (void)device.Write(test::NowIo(), {0.5, true, false, tick++}, &why);
    TelemetrySnapshot status;
    status.ticks = tick;
    device.PublishStatus(test::NowIo(), status);
    ASSERT_TRUE(test::WaitFor([&] { return port.counters().received == tick; })) << "step " << k;
  }
  EXPECT_EQ(device.counters().rx_ok, static_cast<std::uint64_t>(kSteps));

  // The shutdown (Loop::Shutdown): the safe block, with no PublishStatus after it.
  IoError why = IoError::kNone;
  (void)device.Write(test::NowIo(), {0.0, false, true, tick++}, &why);
  GiveTheWorkerTime();
  EXPECT_EQ(port.counters().received, static_cast<std::uint64_t>(kSteps))
      << "the worker wrote the shutdown's block";
  device.Deactivate();
  EXPECT_EQ(port.counters().received,
            static_cast<std::uint64_t>(kSteps) + (shutdown_counted ? 1 : 0))
      << "Deactivate writes the safe block once";
}

TEST(ModbusLockstepCounts, RegisterMapCountsOnlyTheSteps) {
  const int p = test::FreeTcpPort();
  auto port = hil::MakeModbusTcpPort("127.0.0.1:" + std::to_string(p));
  std::string error;
  ASSERT_TRUE(port->Open(&error)) << error;
  ModbusDevice device(LockstepTcp(p, kTimeoutNs));
  RunAndShutDown(*port, device, false);
  port->Close();
}

TEST(ModbusLockstepCounts, DeviceProfileCountsOnlyTheSteps) {
  const auto mp = Float32Profile();
  std::string error;
  const int p = test::FreeTcpPort();
  auto port = hil::MakeModbusProfilePort(false, "127.0.0.1:" + std::to_string(p), mp);
  ASSERT_TRUE(port->Open(&error)) << error;
  ModbusConfig c = LockstepTcp(p, kTimeoutNs);
  c.modbus_profile = mp;
  ModbusDevice device(c);
  RunAndShutDown(*port, device, true);
  port->Close();
}

}  // namespace
}  // namespace mrd::firmware
