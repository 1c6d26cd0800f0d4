// Interop with an implementation we did not write (Debian's python3-pymodbus, driven by
// pymodbus_peer.py, which encodes the register map from docs/modbus_registers.md on its own):
// the firmware's device as a client of pymodbus TCP and RTU servers, and pymodbus as a client
// of mrd-hil's Modbus TCP and RTU ports.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "modbus_test_peers.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "support/io_time.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

using firmware::Bit;
using nlohmann::json;

const std::string kPython = "/usr/bin/python3";
const std::string kPeer = std::string(MRD_SOURCE_DIR) + "/tests/fieldbus/pymodbus_peer.py";

class PymodbusTest : public ::testing::TestWithParam<bool> {  // true: RTU
 protected:
  void SetUp() override {
    if (access(kPython.c_str(), X_OK) != 0 ||
        system((kPython + " -c 'import pymodbus, serial_asyncio' 2>/dev/null").c_str()) != 0) {
      GTEST_FAIL() << "Debian's python3-pymodbus (and python3-serial-asyncio) are needed: "
                      "toolchain/setup.sh installs them";
    }
    port_ = FreeTcpPort();
    link_ = "/tmp/mrd-pymodbus-" + std::to_string(getpid());
    unlink(link_.c_str());
  }
  void TearDown() override { unlink(link_.c_str()); }
  bool Ready() { return GetParam() ? WaitForPath(link_, 10.0) : TcpReady(port_, 10.0); }

  int port_ = 0;
  std::string link_;
};

TEST_P(PymodbusTest, DeviceReadsAndWritesThePymodbusServer) {
  ChildProcess server({kPython, kPeer, GetParam() ? "server-rtu" : "server-tcp",
                       GetParam() ? link_ : std::to_string(port_)});
  ASSERT_TRUE(Ready()) << server.Stderr();
  firmware::ModbusConfig cfg;
  cfg.enabled = true;
  cfg.mode = GetParam() ? firmware::ModbusMode::kRtu : firmware::ModbusMode::kTcp;
  cfg.port = port_;
  cfg.device = link_;
  cfg.response_timeout_ns = 200'000'000;  // an interpreted server: slower than the period
  cfg.poll_period_ns = 5'000'000;
  cfg.inputs = Bit(firmware::Input::kVelocity) | Bit(firmware::Input::kDisplacement) |
               Bit(firmware::Input::kDemand) | Bit(firmware::Input::kBodyVelocity) |
               Bit(firmware::Input::kForce) | Bit(firmware::Input::kFaultLine);
  cfg.outputs = Bit(firmware::Output::kCommand) | Bit(firmware::Output::kEnable) |
                Bit(firmware::Output::kHeartbeat) | Bit(firmware::Output::kStatus);
  firmware::ModbusDevice device(cfg);
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;

  firmware::SensorFrame f;
  firmware::IoError why = firmware::IoError::kNone;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  firmware::IoStatus s = firmware::IoStatus::kNoData;
  while (s != firmware::IoStatus::kOk && std::chrono::steady_clock::now() < until) {
    f = firmware::SensorFrame{};
    s = device.Read(::mrd::test::NowIo(), &f, &why);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(s, firmware::IoStatus::kOk) << firmware::IoErrorName(why) << server.Stderr();
  EXPECT_NEAR(f[firmware::Input::kVelocity].value, -12.3456, 1e-4);
  EXPECT_NEAR(f[firmware::Input::kDisplacement].value, 0.98765, 1e-5);
  EXPECT_NEAR(f[firmware::Input::kDemand].value, 456.78, 1e-2);
  EXPECT_NEAR(f[firmware::Input::kBodyVelocity].value, 3.5, 1e-4);
  EXPECT_NEAR(f[firmware::Input::kForce].value, -321.09, 1e-2);
  EXPECT_FALSE(f.fault_line);

  // Commands until pymodbus has seen two heartbeats with the set-point and enable on.
  std::uint64_t tick = 0;
  while (server.Stdout().empty() && std::chrono::steady_clock::now() < until) {
    (void)device.Read(::mrd::test::NowIo(), &f, &why);
    (void)device.Write(::mrd::test::NowIo(), {1.234, true, false, ++tick}, &why);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_EQ(server.Wait(5.0), 0) << server.Stdout() << server.Stderr();
  device.Deactivate();
  const json c = json::parse(server.Stdout(), nullptr, false);
  ASSERT_FALSE(c.is_discarded()) << server.Stdout();
  EXPECT_NEAR(c["set_point"].get<double>(), 1.234, 1e-9);
  EXPECT_EQ(c["enable"].get<int>(), 1);
  EXPECT_EQ(c["echo"].get<std::uint32_t>(), 7U);  // the seq of the block the loop read
  EXPECT_EQ(c["state"].get<int>(), 2);            // not safe, status carried
  // Nothing refused; writes after the server left (Deactivate's safe block) fail, so count
  // refusals rather than failures.
  const firmware::DeviceCounters n = device.counters();
  EXPECT_EQ(n.rx_rejected, 0U);
  // pymodbus exits once its store holds the second heartbeat, possibly before it answered
  // that write: at least the first was acknowledged.
  EXPECT_GE(n.tx_ok, 1U);
  for (auto e : {firmware::IoError::kException, firmware::IoError::kCrc,
                 firmware::IoError::kRejectedFrame, firmware::IoError::kBadValue}) {
    EXPECT_EQ(n.errors[static_cast<int>(e)], 0U) << firmware::IoErrorName(e);
  }
}

TEST_P(PymodbusTest, PymodbusClientReadsAndWritesTheHarness) {
  const std::string endpoint =
      GetParam() ? "modbus-rtu=" + link_ : "modbus-tcp=127.0.0.1:" + std::to_string(port_);
  ChildProcess hil({std::string(MRD_BIN_DIR) + "/mrd-hil", "serve", "--port", endpoint,
                    "--duration", "3", "--json"});
  ASSERT_TRUE(Ready()) << hil.Stderr();
  ChildProcess client({kPython, kPeer, GetParam() ? "client-rtu" : "client-tcp",
                       GetParam() ? link_ : "127.0.0.1:" + std::to_string(port_)});
  ASSERT_EQ(client.Wait(20.0), 0) << client.Stdout() << client.Stderr();
  ASSERT_EQ(hil.Wait(20.0), 0) << hil.Stderr();
  const json c = json::parse(client.Stdout(), nullptr, false);
  const json h = json::parse(hil.Stdout(), nullptr, false);
  ASSERT_FALSE(c.is_discarded()) << client.Stdout();
  ASSERT_FALSE(h.is_discarded()) << hil.Stdout();
  EXPECT_GT(c["reads"].get<int>(), 20);
  EXPECT_TRUE(c["seq_increasing"].get<bool>());
  // The reference plant: x = A sin(2 pi f t), v = 2 pi f A cos(...), A = 1 cm, f = 2 Hz.
  for (const char* k : {"first", "last"}) {
    EXPECT_LE(std::abs(c[k]["displacement"].get<double>()), 1.0 + 1e-5) << c.dump();
    EXPECT_LE(std::abs(c[k]["velocity"].get<double>()), 4.0 * M_PI + 1e-4) << c.dump();
    EXPECT_EQ(c[k]["faults"].get<int>(), 0);
  }
  // Step `seq` ends at t = seq * 1 ms: the decoded values are the plant's at that instant
  // (a data check that also fails on stuck registers, unlike comparing two reads, which may
  // fall a whole number of 0.5 s cycles apart).
  for (const char* k : {"first", "last"}) {
    const double t = c[k]["seq"].get<double>() * 1e-3;
    EXPECT_NEAR(c[k]["displacement"].get<double>(), std::sin(4.0 * M_PI * t), 1e-3) << c.dump();
    EXPECT_NEAR(c[k]["velocity"].get<double>(), 4.0 * M_PI * std::cos(4.0 * M_PI * t), 1e-2)
        << c.dump();
  }
  EXPECT_GT(c["last"]["seq"].get<double>(), c["first"]["seq"].get<double>());
  EXPECT_TRUE(c["sensor_write_refused"].get<bool>());
  EXPECT_EQ(c["sensor_write_exception"].get<int>(), 2);  // ILLEGAL DATA ADDRESS
  EXPECT_GT(h["commands"].get<std::uint64_t>(), 20U) << h.dump(2);
  EXPECT_GT(h["enabled_steps"].get<std::uint64_t>(), 20U) << h.dump(2);       // enable + heartbeat
  EXPECT_GT(h["latency_us"]["count"].get<std::uint64_t>(), 0U) << h.dump(2);  // echo matched
  EXPECT_EQ(h["invariant_violations"].get<std::uint64_t>(), 0U);
  const json& port = h["ports"][GetParam() ? "modbus-rtu" : "modbus-tcp"];
  EXPECT_EQ(port["rejected"].get<std::uint64_t>(), 1U) << port.dump();  // the sensor write
  EXPECT_GT(port["received"].get<std::uint64_t>(), 20U) << port.dump();
}

INSTANTIATE_TEST_SUITE_P(Transports, PymodbusTest, ::testing::Values(false, true),
                         [](const auto& p) { return std::string(p.param ? "rtu" : "tcp"); });

}  // namespace
}  // namespace mrd::test
