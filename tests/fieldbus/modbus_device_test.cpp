// The Modbus device (firmware/io) against real servers: mrd-hil's libmodbus port on
// 127.0.0.1 and on a pty pair, and scripted peers for the faults (exception response,
// timeout, CRC error, late RTU reply, reserved bits, frozen sensors, peer gone and back, bad
// set-point).
#include "mrd/firmware/io/modbus/modbus_device.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <thread>

#include "modbus_test_peers.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/protocol/modbus_map.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

namespace map = mrd::protocol::modbus;

using test::WaitFor;

ModbusConfig TcpConfig(int port) {
  ModbusConfig c;
  c.enabled = true;
  c.mode = ModbusMode::kTcp;
  c.host = "127.0.0.1";
  c.port = port;
  c.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand) |
             Bit(Input::kBodyVelocity) | Bit(Input::kForce) | Bit(Input::kFaultLine);
  c.outputs =
      Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat) | Bit(Output::kStatus);
  c.response_timeout_ns = 20'000'000;
  c.retries = 1;
  return c;
}

ModbusConfig RtuConfig(const std::string& path) {
  ModbusConfig c = TcpConfig(1);
  c.mode = ModbusMode::kRtu;
  c.device = path;
  return c;
}

std::string PtyPath(const char* tag) {
  return "/tmp/mrd-modbus-" + std::string(tag) + "-" + std::to_string(getpid());
}

hil::SensorOutput Sample(std::uint32_t seq) {
  hil::SensorOutput o;
  o.seq = seq;
  o.sample.v = -12.3456;
  o.sample.x = 0.98765;
  o.sample.demand = 456.78;
  o.sample.body_velocity = 3.5;
  o.sample.force = -321.09;
  o.fault_line = false;
  return o;
}

// Reads until a fresh frame arrives; the frame and status of that Read.
IoStatus ReadFresh(ModbusDevice& d, SensorFrame* f, IoError* why) {
  IoStatus s = IoStatus::kNoData;
  WaitFor([&] {
    *f = SensorFrame{};
    s = d.Read(::mrd::test::NowIo(), f, why);
    return s == IoStatus::kOk;
  });
  return s;
}

// Exchanges a sample and a command with the harness port over the device.
void ExchangeWithHilPort(hil::PlantPort& port, ModbusDevice& device) {
  port.Publish(Sample(41));
  std::string error;
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  SensorFrame f;
  IoError why = IoError::kNone;
  ASSERT_EQ(ReadFresh(device, &f, &why), IoStatus::kOk);
  EXPECT_NEAR(f[Input::kVelocity].value, -12.3456, 1e-4);
  EXPECT_NEAR(f[Input::kDisplacement].value, 0.98765, 1e-5);
  EXPECT_NEAR(f[Input::kDemand].value, 456.78, 1e-2);
  EXPECT_NEAR(f[Input::kBodyVelocity].value, 3.5, 1e-4);
  EXPECT_NEAR(f[Input::kForce].value, -321.09, 1e-2);
  EXPECT_FALSE(f.fault_line);
  EXPECT_GT(f[Input::kVelocity].stamp_ns, 0);

  EXPECT_EQ(device.Write(::mrd::test::NowIo(), {1.234, true, false, 7}, &why), IoStatus::kOk);
  hil::DriverInput in;
  ASSERT_TRUE(WaitFor([&] {
    port.Poll(&in);
    return in.has_command && in.has_echo && in.echo == 41U;
  }));
  EXPECT_NEAR(in.volts, 1.234, 1e-9);
  EXPECT_TRUE(in.has_enable);
  EXPECT_TRUE(in.enable);
  EXPECT_GT(in.heartbeat_ns, 0);

  // The next sample with the fault line asserted.
  hil::SensorOutput faulty = Sample(42);
  faulty.fault_line = true;
  port.Publish(faulty);
  ASSERT_EQ(ReadFresh(device, &f, &why), IoStatus::kOk);
  EXPECT_TRUE(f.fault_line);

  // Deactivate leaves 0 V and enable off on the bus.
  device.Deactivate();
  hil::DriverInput last;
  port.Poll(&last);
  EXPECT_TRUE(last.has_enable);
  EXPECT_FALSE(last.enable);
  EXPECT_EQ(last.volts, 0.0);
  const DeviceCounters c = device.counters();
  EXPECT_GE(c.rx_ok, 2U);
  EXPECT_GE(c.tx_ok, 2U);
  EXPECT_EQ(c.rx_rejected, 0U);
  EXPECT_EQ(c.tx_failed, 0U);
  EXPECT_EQ(port.counters().rejected, 0U);
}

TEST(ModbusDeviceTest, TcpExchangesSensorsAndCommandWithALibmodbusServer) {
  const int p = test::FreeTcpPort();
  auto port = hil::MakeModbusTcpPort("127.0.0.1:" + std::to_string(p));
  std::string error;
  ASSERT_TRUE(port->Open(&error)) << error;
  ModbusDevice device(TcpConfig(p));
  ExchangeWithHilPort(*port, device);
  port->Close();
}

TEST(ModbusDeviceTest, RtuExchangesSensorsAndCommandOverAPty) {
  const std::string path = PtyPath("rtu");
  auto port = hil::MakeModbusRtuPort(path);
  std::string error;
  ASSERT_TRUE(port->Open(&error)) << error;
  ModbusDevice device(RtuConfig(path));
  ExchangeWithHilPort(*port, device);
  port->Close();
}

TEST(ModbusDeviceTest, ExceptionResponseIsAFaultAndCounted) {
  const int p = test::FreeTcpPort();
  test::ScriptedTcpServer server(p, test::PeerBehaviour::kException);
  ASSERT_TRUE(server.listening());
  ModbusDevice device(TcpConfig(p));
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  SensorFrame f;
  IoError why = IoError::kNone;
  ASSERT_TRUE(
      WaitFor([&] { return device.Read(::mrd::test::NowIo(), &f, &why) == IoStatus::kFault; }));
  EXPECT_EQ(why, IoError::kException);
  EXPECT_TRUE(std::isnan(f[Input::kVelocity].value));  // nothing was ever accepted
  const DeviceCounters c = device.counters();
  EXPECT_GT(c.errors[static_cast<int>(IoError::kException)], 0U);
  EXPECT_GT(c.rx_rejected, 0U);
  EXPECT_EQ(c.rx_ok, 0U);
}

TEST(ModbusDeviceTest, SilentPeerTimesOutAndTheTickKeepsReturning) {
  const int p = test::FreeTcpPort();
  test::ScriptedTcpServer server(p, test::PeerBehaviour::kSilent);
  ModbusConfig cfg = TcpConfig(p);
  // Long enough that the test's first Read comes before the timeout even when a loaded
  // machine deschedules the test thread for a while (it did at 5 ms).
  cfg.response_timeout_ns = 200'000'000;
  ModbusDevice device(cfg);
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  SensorFrame f;
  IoError why = IoError::kNone;
  int reads = 0;
  ASSERT_TRUE(WaitFor([&] {
    ++reads;
    return device.Read(::mrd::test::NowIo(), &f, &why) == IoStatus::kFault;
  }));
  EXPECT_EQ(why, IoError::kTimeout);
  EXPECT_GT(reads, 1);  // Read returned (kNoData) while the worker waited on the peer
  EXPECT_TRUE(WaitFor([&] {
    return device.counters().errors[static_cast<int>(IoError::kTimeout)] >= 2U;  // + retry
  }));
  EXPECT_EQ(device.counters().rx_ok, 0U);
  EXPECT_GT(server.requests(), 0);
}

TEST(ModbusDeviceTest, RtuCrcErrorIsRejectedAndCounted) {
  const std::string path = PtyPath("crc");
  test::ScriptedRtuPeer peer(path, test::RtuScript::kBadCrc);
  ModbusDevice device(RtuConfig(path));
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  SensorFrame f;
  IoError why = IoError::kNone;
  ASSERT_TRUE(WaitFor([&] {
    return device.Read(::mrd::test::NowIo(), &f, &why) == IoStatus::kFault && why == IoError::kCrc;
  }));
  EXPECT_GT(peer.answers(), 0);
  const DeviceCounters c = device.counters();
  EXPECT_GT(c.errors[static_cast<int>(IoError::kCrc)], 0U);
  EXPECT_GT(c.rx_rejected, 0U);
  EXPECT_EQ(c.rx_ok, 0U);
}

// RTU has no transaction id: a reply that comes after the timeout must be discarded, not
// taken as the answer to the retry (and every reply after it refused as the wrong one).
TEST(ModbusDeviceTest, RtuLateReplyIsDiscardedNotTakenForTheNextRequest) {
  const std::string path = PtyPath("late");
  test::ScriptedRtuPeer peer(path, test::RtuScript::kLateOnce, /*late_index=*/6,
                             /*late_ms=*/35);  // the device waits 20 ms
  ModbusDevice device(RtuConfig(path));
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  IoError why = IoError::kNone;
  std::uint64_t tick = 0;
  ASSERT_TRUE(WaitFor([&] {  // reads and writes interleaved, as the loop drives them
    (void)device.Write(::mrd::test::NowIo(), {1.0, true, false, ++tick}, &why);
    return peer.answers() > 40;
  }));
  device.Deactivate();
  const DeviceCounters c = device.counters();
  EXPECT_EQ(c.errors[static_cast<int>(IoError::kTimeout)], 1U);
  EXPECT_EQ(c.errors[static_cast<int>(IoError::kRejectedFrame)], 0U);
  EXPECT_EQ(c.errors[static_cast<int>(IoError::kCrc)], 0U);
  EXPECT_EQ(c.rx_rejected, 0U);
  EXPECT_EQ(c.tx_failed, 0U);  // the retry after the quiet line got its own answer
  EXPECT_GT(c.rx_ok, 10U);
  EXPECT_GT(c.tx_ok, 10U);
}

TEST(ModbusDeviceTest, ReservedFaultBitsAreABadValue) {
  const int p = test::FreeTcpPort();
  test::ScriptedTcpServer server(p, test::PeerBehaviour::kAnswer);
  server.SetRegister(map::kSensorBase + map::kFaults, 0x0080);
  ModbusDevice device(TcpConfig(p));
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  SensorFrame f;
  IoError why = IoError::kNone;
  ASSERT_TRUE(
      WaitFor([&] { return device.Read(::mrd::test::NowIo(), &f, &why) == IoStatus::kFault; }));
  EXPECT_EQ(why, IoError::kBadValue);
  EXPECT_EQ(device.counters().rx_ok, 0U);
  EXPECT_GT(device.counters().errors[static_cast<int>(IoError::kBadValue)], 0U);
}

TEST(ModbusDeviceTest, FrozenSensorBlockIsNotNewDataAndKeepsItsStamp) {
  const int p = test::FreeTcpPort();
  test::ScriptedTcpServer server(p, test::PeerBehaviour::kAnswer);
  server.SetRegister(map::kSensorBase + map::kSeq + 1, 5);
  ModbusDevice device(TcpConfig(p));
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  SensorFrame f;
  IoError why = IoError::kNone;
  ASSERT_EQ(ReadFresh(device, &f, &why), IoStatus::kOk);
  const std::int64_t stamp = f[Input::kVelocity].stamp_ns;
  const int before = server.requests();
  ASSERT_TRUE(WaitFor([&] { return server.requests() > before + 5; }));
  SensorFrame g;
  EXPECT_EQ(device.Read(::mrd::test::NowIo(), &g, &why), IoStatus::kNoData);
  EXPECT_EQ(g[Input::kVelocity].stamp_ns, stamp);  // the latest value, with its old stamp
  EXPECT_EQ(device.counters().rx_ok, 1U);
}

TEST(ModbusDeviceTest, SetPointOutsideTheRegisterIsNotSent) {
  const int p = test::FreeTcpPort();
  test::ScriptedTcpServer server(p, test::PeerBehaviour::kAnswer);
  ModbusDevice device(TcpConfig(p));
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  IoError why = IoError::kNone;
  (void)device.Write(::mrd::test::NowIo(), {100.0, true, false, 1}, &why);  // > 32.767 V
  ASSERT_TRUE(WaitFor([&] { return device.counters().tx_failed > 0; }));
  EXPECT_EQ(device.counters().errors[static_cast<int>(IoError::kBadValue)], 1U);
  EXPECT_EQ(server.Register(map::kCommandBase + map::kSetPoint), 0U);  // never written
  // The loop hears of it (same tick: nothing new to send).
  EXPECT_TRUE(WaitFor([&] {
    return device.Write(::mrd::test::NowIo(), {100.0, true, false, 1}, &why) == IoStatus::kFault;
  }));
  EXPECT_EQ(why, IoError::kBadValue);
  (void)device.Write(::mrd::test::NowIo(), {1.0, true, false, 2}, &why);
  ASSERT_TRUE(
      WaitFor([&] { return server.Register(map::kCommandBase + map::kSetPoint) == 1000U; }));
}

TEST(ModbusDeviceTest, PeerGoneIsDisconnectedAndReconnectsWhenItComesBack) {
  const int p = test::FreeTcpPort();
  auto port = hil::MakeModbusTcpPort("127.0.0.1:" + std::to_string(p));
  std::string error;
  ASSERT_TRUE(port->Open(&error)) << error;
  port->Publish(Sample(1));
  ModbusDevice device(TcpConfig(p));
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  SensorFrame f;
  IoError why = IoError::kNone;
  ASSERT_EQ(ReadFresh(device, &f, &why), IoStatus::kOk);
  const std::int64_t stamp = f[Input::kVelocity].stamp_ns;

  port->Close();
  port.reset();
  ASSERT_TRUE(WaitFor([&] {
    f = SensorFrame{};
    return device.Read(::mrd::test::NowIo(), &f, &why) == IoStatus::kFault;
  }));
  EXPECT_EQ(why, IoError::kDisconnected);
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, stamp);  // stale: the old stamp ages
  EXPECT_TRUE(WaitFor([&] {
    return device.Write(::mrd::test::NowIo(), {1.0, true, false, 3}, &why) == IoStatus::kFault;
  }));

  auto again = hil::MakeModbusTcpPort("127.0.0.1:" + std::to_string(p));
  ASSERT_TRUE(again->Open(&error)) << error;
  again->Publish(Sample(1));  // a restarted peer may repeat a seq: still new data
  ASSERT_EQ(ReadFresh(device, &f, &why), IoStatus::kOk);
  EXPECT_GT(f[Input::kVelocity].stamp_ns, stamp);
  EXPECT_GE(device.counters().reconnects, 1U);
  EXPECT_GT(device.counters().errors[static_cast<int>(IoError::kDisconnected)], 0U);
  device.Deactivate();
  again->Close();
}

}  // namespace
}  // namespace mrd::firmware
