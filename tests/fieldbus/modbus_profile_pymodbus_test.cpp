// The shipped modbus-float32 device profile against an implementation we did not write:
// Debian's python3-pymodbus serving that map, encoded on its own in pymodbus_float32.py from
// docs/devices.md (swapped float32 words through Python's struct). The firmware's device,
// configured by the profile file, reads the sensor values pymodbus holds at unit 1 and writes
// a set-point and enable that pymodbus decodes at unit 2; a NaN pymodbus serves is refused
// (bad_value, the loop's safe state). Over TCP and RTU (a pty null-modem).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "modbus_test_peers.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "support/io_time.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

using firmware::Bit;
using nlohmann::json;

const std::string kPython = "/usr/bin/python3";
const std::string kPeer = std::string(MRD_SOURCE_DIR) + "/tests/fieldbus/pymodbus_float32.py";
const std::string kProfile = std::string(MRD_SOURCE_DIR) + "/firmware/profiles/modbus-float32.toml";

class ModbusProfilePymodbusTest : public ::testing::TestWithParam<bool> {  // true: RTU
 protected:
  void SetUp() override {
    if (access(kPython.c_str(), X_OK) != 0 ||
        system((kPython + " -c 'import pymodbus, serial_asyncio' 2>/dev/null").c_str()) != 0) {
      GTEST_FAIL() << "Debian's python3-pymodbus (and python3-serial-asyncio) are needed: "
                      "toolchain/setup.sh installs them";
    }
    port_ = FreeTcpPort();
    link_ = "/tmp/mrd-pymodbus-f32-" + std::to_string(getpid());
    unlink(link_.c_str());
    auto p = std::make_shared<profile::ModbusProfile>();
    std::string error;
    ASSERT_TRUE(profile::LoadModbusProfile(kProfile, p.get(), &error)) << error;
    profile_ = p;
  }
  void TearDown() override { unlink(link_.c_str()); }

  std::unique_ptr<ChildProcess> Server(bool nan) {
    std::vector<std::string> args = {
        kPython,     kPeer, GetParam() ? "rtu" : "tcp", GetParam() ? link_ : std::to_string(port_),
        "--seconds", "15"};
    if (nan) args.push_back("--nan");
    auto server = std::make_unique<ChildProcess>(args);
    const bool ready = GetParam() ? WaitForPath(link_, 10.0) : TcpReady(port_, 10.0);
    EXPECT_TRUE(ready) << server->Stderr();
    return server;
  }

  firmware::ModbusConfig Config() const {
    firmware::ModbusConfig cfg;
    cfg.enabled = true;
    cfg.mode = GetParam() ? firmware::ModbusMode::kRtu : firmware::ModbusMode::kTcp;
    cfg.port = port_;
    cfg.device = link_;
    cfg.response_timeout_ns = 200'000'000;  // an interpreted server: slower than the period
    cfg.poll_period_ns = 5'000'000;
    cfg.modbus_profile = profile_;
    cfg.inputs = Bit(firmware::Input::kVelocity) | Bit(firmware::Input::kDisplacement) |
                 Bit(firmware::Input::kDemand) | Bit(firmware::Input::kBodyVelocity) |
                 Bit(firmware::Input::kForce) | Bit(firmware::Input::kFaultLine);
    cfg.outputs = Bit(firmware::Output::kCommand) | Bit(firmware::Output::kEnable) |
                  Bit(firmware::Output::kHeartbeat) | Bit(firmware::Output::kStatus);
    return cfg;
  }

  int port_ = 0;
  std::string link_;
  std::shared_ptr<const profile::ModbusProfile> profile_;
};

TEST_P(ModbusProfilePymodbusTest, ReadsUnit1AndWritesUnit2OfThePymodbusServer) {
  auto server = Server(/*nan=*/false);
  firmware::ModbusDevice device(Config());
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;

  firmware::SensorFrame f;
  firmware::IoError why = firmware::IoError::kNone;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(12);
  firmware::IoStatus s = firmware::IoStatus::kNoData;
  while (s != firmware::IoStatus::kOk && std::chrono::steady_clock::now() < until) {
    f = firmware::SensorFrame{};
    s = device.Read(::mrd::test::NowIo(), &f, &why);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(s, firmware::IoStatus::kOk) << firmware::IoErrorName(why) << server->Stderr();
  // float32 values: exact to the float's precision (a wrong word order gives nonsense).
  EXPECT_NEAR(f[firmware::Input::kVelocity].value, -12.3456, 1e-5);
  EXPECT_NEAR(f[firmware::Input::kDisplacement].value, 0.98765, 1e-6);
  EXPECT_NEAR(f[firmware::Input::kDemand].value, 456.78, 1e-4);
  EXPECT_NEAR(f[firmware::Input::kBodyVelocity].value, 3.5, 1e-6);
  EXPECT_NEAR(f[firmware::Input::kForce].value, -321.09, 1e-4);
  EXPECT_FALSE(f.fault_line);

  // Live telemetry of a period (status_model_force, _demand, _command at unit 2, 8..13).
  firmware::TelemetrySnapshot stats;
  stats.safe = false;
  stats.model_force_n = 321.5;
  stats.force_demand_n = -45.25;
  stats.last_command_v = 1.234;
  device.PublishStatus(::mrd::test::NowIo(), stats);
  // Commands until pymodbus has seen two heartbeats with the set-point and the enable on.
  std::uint64_t tick = 0;
  while (server->Stdout().empty() && std::chrono::steady_clock::now() < until) {
    (void)device.Read(::mrd::test::NowIo(), &f, &why);
    (void)device.Write(::mrd::test::NowIo(), {1.234, true, false, ++tick}, &why);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_EQ(server->Wait(5.0), 0) << server->Stdout() << server->Stderr();
  device.Deactivate();
  const json c = json::parse(server->Stdout(), nullptr, false);
  ASSERT_FALSE(c.is_discarded()) << server->Stdout();
  EXPECT_NEAR(c["set_point"].get<double>(), 1.234, 1e-6);  // float32 of 1.234 V
  EXPECT_EQ(c["enable"].get<int>(), 1);
  EXPECT_EQ(c["safe"].get<int>(), 0);
  EXPECT_GE(c["echo"].get<std::uint32_t>(), 1U);  // a seq pymodbus served
  EXPECT_LE(c["echo"].get<std::uint32_t>(), c["seq"].get<std::uint32_t>());
  // pymodbus decoded the telemetry registers as the firmware's figures (float32, swapped words).
  ASSERT_TRUE(c["telemetry"].is_object()) << server->Stdout();
  EXPECT_NEAR(c["telemetry"]["model_force"].get<double>(), 321.5, 1e-4);
  EXPECT_NEAR(c["telemetry"]["demand"].get<double>(), -45.25, 1e-4);
  EXPECT_NEAR(c["telemetry"]["command"].get<double>(), 1.234, 1e-6);
  // As pymodbus decoded the requests: input registers of unit 1 in one read of 16, unit 2's
  // driver_faults, the enable coil with 0x0F, the telemetry block and the command block with
  // 0x10, nothing else.
  std::set<std::vector<int>> seen;
  for (const auto& r : c["requests"]) {
    seen.insert(
        {r[0].get<int>(), r[1].get<int>(), r[2].get<int>(), r[3].is_null() ? -1 : r[3].get<int>()});
  }
  const std::set<std::vector<int>> want = {
      {1, 0x04, 0, 16}, {2, 0x04, 0, 1}, {2, 0x0F, 0, 1}, {2, 0x10, 8, 6}, {2, 0x10, 0, 7}};
  EXPECT_EQ(seen, want) << c["requests"].dump();
  const firmware::DeviceCounters n = device.counters();
  EXPECT_EQ(n.rx_rejected, 0U);
  EXPECT_GE(n.tx_ok, 1U);
  for (auto e : {firmware::IoError::kException, firmware::IoError::kCrc,
                 firmware::IoError::kRejectedFrame, firmware::IoError::kBadValue}) {
    EXPECT_EQ(n.errors[static_cast<int>(e)], 0U) << firmware::IoErrorName(e);
  }
}

TEST_P(ModbusProfilePymodbusTest, ANanFromTheServerIsABadValue) {
  auto server = Server(/*nan=*/true);
  firmware::ModbusDevice device(Config());
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  firmware::SensorFrame f;
  firmware::IoError why = firmware::IoError::kNone;
  firmware::IoStatus s = firmware::IoStatus::kNoData;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(12);
  while (s != firmware::IoStatus::kFault && std::chrono::steady_clock::now() < until) {
    f = firmware::SensorFrame{};
    s = device.Read(::mrd::test::NowIo(), &f, &why);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  device.Deactivate();
  ASSERT_EQ(s, firmware::IoStatus::kFault) << server->Stderr();
  EXPECT_EQ(why, firmware::IoError::kBadValue);
  const firmware::DeviceCounters n = device.counters();
  EXPECT_EQ(n.rx_ok, 0U);  // no sample with the NaN reached the loop
  EXPECT_GE(n.errors[static_cast<int>(firmware::IoError::kBadValue)], 1U);
}

INSTANTIATE_TEST_SUITE_P(Transports, ModbusProfilePymodbusTest, ::testing::Values(false, true),
                         [](const auto& p) { return std::string(p.param ? "rtu" : "tcp"); });

}  // namespace
}  // namespace mrd::test
