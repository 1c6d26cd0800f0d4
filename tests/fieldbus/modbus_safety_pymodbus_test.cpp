// A Modbus driver's safety features against a peer we did not write (labels profile, fieldbus,
// conformance): Debian's python3-pymodbus serving the modbus-float32 map on its own
// (pymodbus_safety.py, from docs/devices.md). The firmware's device must (1) still write the
// set-point and heartbeat block, with the safe values, in the very cycle its enable write is
// refused with an exception; (2) take the driver's driver_faults register as the fault line
// when [modbus] inputs does not route fault_line. And the firmware itself (3, 4) refuses to
// start, writing nothing to the peer, on a profile whose safe state drives the coil or whose
// command range the register cannot hold. Over TCP and RTU (a pty null-modem).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
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
const std::string kPeer = std::string(MRD_SOURCE_DIR) + "/tests/fieldbus/pymodbus_safety.py";
const std::string kProfile = std::string(MRD_SOURCE_DIR) + "/firmware/profiles/modbus-float32.toml";
constexpr int kFaultLineBit = 1 << 4;  // watchdog cause 4 (docs/modbus_registers.md)

class ModbusSafetyPymodbusTest : public ::testing::TestWithParam<bool> {  // true: RTU
 protected:
  void SetUp() override {
    if (access(kPython.c_str(), X_OK) != 0 ||
        system((kPython + " -c 'import pymodbus, serial_asyncio' 2>/dev/null").c_str()) != 0) {
      GTEST_FAIL() << "Debian's python3-pymodbus (and python3-serial-asyncio) are needed: "
                      "toolchain/setup.sh installs them";
    }
    port_ = FreeTcpPort();
    link_ = "/tmp/mrd-pymodbus-safety-" + std::to_string(getpid());
    unlink(link_.c_str());
    auto p = std::make_shared<profile::ModbusProfile>();
    std::string error;
    ASSERT_TRUE(profile::LoadModbusProfile(kProfile, p.get(), &error)) << error;
    profile_ = p;
  }
  void TearDown() override { unlink(link_.c_str()); }

  std::unique_ptr<ChildProcess> Peer(const std::string& mode, double seconds = 15.0) {
    auto peer = std::make_unique<ChildProcess>(std::vector<std::string>{
        kPython, kPeer, GetParam() ? "rtu" : "tcp", GetParam() ? link_ : std::to_string(port_),
        mode, "--seconds", std::to_string(seconds)});
    const bool ready = GetParam() ? WaitForPath(link_, 10.0) : TcpReady(port_, 10.0);
    EXPECT_TRUE(ready) << peer->Stderr();
    return peer;
  }

  firmware::ModbusConfig Config(bool route_fault_line) const {
    firmware::ModbusConfig cfg;
    cfg.enabled = true;
    cfg.mode = GetParam() ? firmware::ModbusMode::kRtu : firmware::ModbusMode::kTcp;
    cfg.port = port_;
    cfg.device = link_;
    cfg.response_timeout_ns = 200'000'000;  // an interpreted server
    cfg.poll_period_ns = 5'000'000;
    cfg.modbus_profile = profile_;
    cfg.inputs = Bit(firmware::Input::kVelocity) | Bit(firmware::Input::kDisplacement) |
                 Bit(firmware::Input::kDemand);
    if (route_fault_line) cfg.inputs |= Bit(firmware::Input::kFaultLine);
    cfg.outputs = Bit(firmware::Output::kCommand) | Bit(firmware::Output::kEnable) |
                  Bit(firmware::Output::kHeartbeat) | Bit(firmware::Output::kStatus);
    return cfg;
  }

  // Drives the device as the loop would: a driving command every 2 ms until it sees a fault
  // (a failed write, or a frame with the fault line), then the safe state with the cause
  // fault_line or driver_fault. Until the peer has printed its verdict. *fault_line: a frame
  // carried it.
  void Drive(firmware::ModbusDevice& device, ChildProcess& peer, bool* fault_line) {
    firmware::SensorFrame f;
    firmware::IoError why = firmware::IoError::kNone;
    bool safe = false;
    std::uint16_t causes = 0;
    std::uint64_t tick = 0;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(14);
    while (peer.Stdout().empty() && std::chrono::steady_clock::now() < until) {
      f = firmware::SensorFrame{};
      (void)device.Read(NowIo(), &f, &why);
      if (f.fault_line) {
        *fault_line = true;
        safe = true;
        causes = kFaultLineBit;
      }
      firmware::TelemetrySnapshot stats;
      stats.safe = safe;
      stats.active_causes = causes;
      device.PublishStatus(NowIo(), stats);
      const firmware::IoStatus w =
          device.Write(NowIo(), {safe ? 0.0 : 1.5, !safe, safe, ++tick}, &why);
      if (w == firmware::IoStatus::kFault && !safe) {
        safe = true;
        causes = 1 << 3;  // driver_fault
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }

  int port_ = 0;
  std::string link_;
  std::shared_ptr<const profile::ModbusProfile> profile_;
};

// (1) The enable coil write answered with exception 0x04: the holding block still goes out,
// in the same cycle, with set-point 0 and the safe flag; the heartbeat keeps changing.
TEST_P(ModbusSafetyPymodbusTest, ARefusedEnableWriteStillSendsTheSafeSetpointBlock) {
  auto peer = Peer("enable-refused");
  firmware::ModbusDevice device(Config(true));
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  bool fault_line = false;
  Drive(device, *peer, &fault_line);
  ASSERT_EQ(peer->Wait(5.0), 0) << peer->Stderr();
  device.Deactivate();
  const json c = json::parse(peer->Stdout(), nullptr, false);
  ASSERT_FALSE(c.is_discarded()) << peer->Stdout();
  ASSERT_TRUE(c["fault_at"].is_number()) << "never drove 20 blocks: " << peer->Stdout();
  const auto at = c["fault_at"].get<std::size_t>();
  const json& blocks = c["blocks"];
  ASSERT_GT(blocks.size(), at) << "no command block reached the driver after its enable write "
                                  "was refused (the cycle stopped at the exception)";
  // The first block after the refusal began is the refused cycle's own: safe values already.
  EXPECT_EQ(blocks[at][0].get<double>(), 0.0) << blocks[at].dump();
  EXPECT_EQ(blocks[at][4].get<int>(), 1) << blocks[at].dump();
  EXPECT_EQ(blocks[at][1].get<int>(), 1) << "the coil kept its value (the write was refused)";
  for (std::size_t i = at; i < blocks.size(); ++i) {
    EXPECT_EQ(blocks[i][0].get<double>(), 0.0) << i << ": " << blocks[i].dump();
  }
  EXPECT_GE(c["refused"].get<int>(), 2);
  const firmware::DeviceCounters n = device.counters();
  EXPECT_GE(n.errors[static_cast<int>(firmware::IoError::kException)], 2U);
}

// (2) driver_faults mapped, fault_line not routed: the driver's fault report is the fault line.
TEST_P(ModbusSafetyPymodbusTest, DriverFaultsCountWithoutFaultLineRouting) {
  auto peer = Peer("driver-fault");
  firmware::ModbusDevice device(Config(false));
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  bool fault_line = false;
  Drive(device, *peer, &fault_line);
  ASSERT_EQ(peer->Wait(5.0), 0) << peer->Stderr();
  device.Deactivate();
  EXPECT_TRUE(fault_line) << "the driver's faults were never taken";
  const json c = json::parse(peer->Stdout(), nullptr, false);
  ASSERT_FALSE(c.is_discarded()) << peer->Stdout();
  ASSERT_TRUE(c["fault_at"].is_number()) << peer->Stdout();
  bool answered = false;
  for (const auto& b : c["blocks"]) {
    answered = answered || (b[4].get<int>() == 1 && (b[3].get<int>() & kFaultLineBit) != 0);
  }
  EXPECT_TRUE(answered) << c["blocks"].dump();
}

// (3, 4) mrd-firmware on an unsafe profile: refused at start (exit 2), nothing written.
TEST_P(ModbusSafetyPymodbusTest, TheFirmwareRefusesAnUnsafeProfileAndWritesNothing) {
  const std::string dir = ::testing::TempDir();
  std::ifstream in(kProfile);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string shipped = ss.str();
  const auto edit = [&](const std::string& from, const std::string& to) {
    std::string t = shipped;
    const auto at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return t.replace(at, from.size(), to);
  };
  std::ofstream(dir + "/falling.csv") << "E,V\n0,24\n2.25,0\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"falling", edit("min = 0.0", "calibration = \"falling.csv\"\nmin = 0.0")},
      {"max-beyond",
       edit("command = { unit = 2, table = \"holding\", address = 0, type = \"float32\" }",
            "command = { unit = 2, table = \"holding\", address = 0, type = \"int16\", "
            "scale = 0.001 }")},
  };
  for (const auto& [name, text] : cases) {
    std::string profile_text = text;
    if (name == "max-beyond") {  // 40 V: beyond an int16 of mV (32.767 V)
      profile_text.replace(profile_text.find("max = 24.0"), 10, "max = 40.0");
    }
    const std::string profile = dir + "/" + name + ".toml";
    std::ofstream(profile) << profile_text;
    const std::string cfg = dir + "/fw-" + name + ".toml";
    std::ofstream(cfg) << "[modbus]\n"
                       << (GetParam() ? "mode = \"rtu\"\ndevice = \"" + link_ + "\"\n"
                                      : "mode = \"tcp\"\nport = " + std::to_string(port_) + "\n")
                       << "profile = \"" << profile << "\"\ninputs = [\"velocity\", \"demand\"]\n"
                       << "outputs = [\"command\", \"enable\"]\n";
    auto peer = Peer("record", 4.0);
    ChildProcess fw({std::string(MRD_BIN_DIR) + "/mrd-firmware", "--config", cfg,
                     "--allow-demo-table", "--duration", "1"});
    EXPECT_EQ(fw.Wait(20.0), 2) << name << ": " << fw.Stderr();
    EXPECT_NE(fw.Stderr().find(name == "falling" ? "the calibration falls as E rises"
                                                 : "command.max 40 V is beyond"),
              std::string::npos)
        << fw.Stderr();
    peer->Signal(SIGTERM);
    ASSERT_EQ(peer->Wait(5.0), 0) << peer->Stderr();
    const json c = json::parse(peer->Stdout(), nullptr, false);
    ASSERT_FALSE(c.is_discarded()) << peer->Stdout();
    EXPECT_TRUE(c["writes"].empty()) << name << ": " << c["writes"].dump();
    EXPECT_TRUE(c["blocks"].empty()) << name << ": " << c["blocks"].dump();
  }
}

// The shipped profile with a start-up write (the driver's watchdog timeout, holding 14) and a
// keep-alive every 50 ms (holding 15) under a 300 ms watchdog; `startup_address` moves the
// start-up write (beyond the peer's 16 registers: refused with exception 0x02).
std::string WithWatchdogWrites(const std::string& shipped, int startup_address) {
  return shipped + "\n[[modbus.startup]]\nunit = 2\ntable = \"holding\"\naddress = " +
         std::to_string(startup_address) +
         "\nvalue = 300\n\n[[modbus.periodic]]\nunit = 2\ntable = \"holding\"\n"
         "address = 15\nvalue = 1\nperiod_ms = 50\nwatchdog_ms = 300\n";
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// (13) The start-up write goes out once, before any other write of the connection; the
// keep-alive goes out periodically from the worker's cycle.
TEST_P(ModbusSafetyPymodbusTest, StartUpWriteFirstThenThePeriodicKeepAlive) {
  const std::string path = ::testing::TempDir() + "/watchdog-" + std::to_string(getpid()) + ".toml";
  std::ofstream(path) << WithWatchdogWrites(Slurp(kProfile), 14);
  auto p = std::make_shared<profile::ModbusProfile>();
  std::string error;
  ASSERT_TRUE(profile::LoadModbusProfile(path, p.get(), &error)) << error;
  profile_ = p;
  auto peer = Peer("record", 1.5);
  firmware::ModbusDevice device(Config(true));
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  bool fault_line = false;
  Drive(device, *peer, &fault_line);
  ASSERT_EQ(peer->Wait(5.0), 0) << peer->Stderr();
  device.Deactivate();
  const json c = json::parse(peer->Stdout(), nullptr, false);
  ASSERT_FALSE(c.is_discarded()) << peer->Stdout();
  const json& w = c["writes"];
  ASSERT_FALSE(w.empty());
  EXPECT_EQ(w[0], json({2, 6, 14})) << "the start-up write first, not " << w[0].dump();
  int startups = 0, keepalives = 0, blocks = 0;
  for (const auto& x : w) {
    startups += x == json({2, 6, 14});
    keepalives += x == json({2, 6, 15});
    blocks += x[1].get<int>() == 0x10;
  }
  EXPECT_EQ(startups, 1);
  EXPECT_GE(keepalives, 5) << "about 1.5 s / 50 ms expected";
  EXPECT_GT(blocks, keepalives) << "keep-alives come at their own period, not every cycle";
  EXPECT_EQ(device.counters().errors[static_cast<int>(firmware::IoError::kException)], 0U);
}

// (13) A start-up write the driver refuses: mrd-firmware does not start (exit 1, as for a
// refused CANopen SDO) and names the register and the profile's line.
TEST_P(ModbusSafetyPymodbusTest, ARefusedStartUpWriteIsAStartUpErrorNamingTheRegister) {
  const std::string dir = ::testing::TempDir();
  const std::string profile = dir + "/refused-startup-" + std::to_string(getpid()) + ".toml";
  std::ofstream(profile) << WithWatchdogWrites(Slurp(kProfile), 100);
  const std::string cfg = dir + "/fw-refused-startup-" + std::to_string(getpid()) + ".toml";
  std::ofstream(cfg) << "[modbus]\n"
                     << (GetParam() ? "mode = \"rtu\"\ndevice = \"" + link_ + "\"\n"
                                    : "mode = \"tcp\"\nport = " + std::to_string(port_) + "\n")
                     << "profile = \"" << profile << "\"\ninputs = [\"velocity\", \"demand\"]\n"
                     << "outputs = [\"command\", \"enable\"]\nresponse_timeout_ms = 2000\n";
  auto peer = Peer("record", 6.0);
  ChildProcess fw({std::string(MRD_BIN_DIR) + "/mrd-firmware", "--config", cfg,
                   "--allow-demo-table", "--duration", "2"});
  EXPECT_EQ(fw.Wait(20.0), 1) << fw.Stderr();
  EXPECT_NE(fw.Stderr().find("the start-up write of unit 2 holding register 100 = 300 was "
                             "refused (exception 0x02)"),
            std::string::npos)
      << fw.Stderr();
  EXPECT_NE(fw.Stderr().find(profile + ":"), std::string::npos) << fw.Stderr();  // FILE:LINE
  peer->Signal(SIGTERM);
  ASSERT_EQ(peer->Wait(5.0), 0) << peer->Stderr();
}

// (14) A driver that latches its fault until a reset edge on coil 1 (fault_reset): with the
// firmware clean but for the driver's fault, the device edges the reset at most once per
// fault_reset_ms (1 s); the peer ignores the first edge and clears on the second; no edge after.
TEST_P(ModbusSafetyPymodbusTest, ALatchedDriverFaultIsResetByARateLimitedEdge) {
  const std::string path =
      ::testing::TempDir() + "/fault-reset-" + std::to_string(getpid()) + ".toml";
  std::string text = Slurp(kProfile);
  text.replace(text.find("max_read = 125\n"), 15, "max_read = 125\nfault_reset_ms = 1000\n");
  text += "\n[modbus.outputs.fault_reset]\nunit = 2\ntable = \"coil\"\naddress = 1\n";
  std::ofstream(path) << text;
  auto p = std::make_shared<profile::ModbusProfile>();
  std::string error;
  ASSERT_TRUE(profile::LoadModbusProfile(path, p.get(), &error)) << error;
  ASSERT_EQ(p->fault_reset_ms, 1000);
  profile_ = p;
  auto peer = Peer("latched-fault");
  firmware::ModbusDevice device(Config(false));
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  bool fault_line = false;
  Drive(device, *peer, &fault_line);
  ASSERT_EQ(peer->Wait(5.0), 0) << peer->Stderr();
  device.Deactivate();
  EXPECT_TRUE(fault_line);
  const json c = json::parse(peer->Stdout(), nullptr, false);
  ASSERT_FALSE(c.is_discarded()) << peer->Stdout();
  const json& resets = c["resets"];
  ASSERT_EQ(resets.size(), 2U) << "one edge per second until cleared, then none: " << resets.dump();
  EXPECT_GE(resets[1].get<double>(), 0.95) << "rate-limited to one edge per fault_reset_ms";
  EXPECT_LT(resets[1].get<double>(), 3.0) << "the second edge came late";
}

INSTANTIATE_TEST_SUITE_P(Transports, ModbusSafetyPymodbusTest, ::testing::Values(false, true),
                         [](const auto& p) { return std::string(p.param ? "rtu" : "tcp"); });

}  // namespace
}  // namespace mrd::test
