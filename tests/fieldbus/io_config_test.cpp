// The bus sections of the firmware configuration: routing of inputs and outputs, connection
// settings, and every refusal with its line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "mrd/firmware/platform/config.hpp"

namespace mrd::firmware {
namespace {

bool Parse(const std::string& text, platform::FirmwareConfig* c, std::string* error) {
  return platform::ParseConfig(text, "fw.toml", c, error);
}

// The error for text, or "" when it parses.
std::string ErrorOf(const std::string& text) {
  platform::FirmwareConfig c;
  std::string error;
  return Parse(text, &c, &error) ? "" : error;
}

TEST(IoConfigTest, NoBusSectionMeansDryRun) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(Parse("[control]\nlaw = \"force\"\n", &c, &error)) << error;
  EXPECT_FALSE(c.io.any());
}

TEST(IoConfigTest, ReadsCanRouting) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(Parse(R"([can]
local_bus = "/tmp/bus.sock"
inputs = ["velocity", "demand"]
outputs = ["command", "heartbeat"]
tx_deadline_us = 300
status_period_ms = 50
)",
                    &c, &error))
      << error;
  EXPECT_TRUE(c.io.can.enabled);
  EXPECT_EQ(c.io.can.inputs, Bit(Input::kVelocity) | Bit(Input::kDemand));
  EXPECT_EQ(c.io.can.outputs, Bit(Output::kCommand) | Bit(Output::kHeartbeat));
  EXPECT_EQ(c.io.can.local_bus, "/tmp/bus.sock");
  EXPECT_EQ(c.io.can.tx_deadline_ns, 300'000);
  EXPECT_EQ(c.io.can.status_period_ns, 50'000'000);
}

TEST(IoConfigTest, ReadsModbusRtuSettings) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(Parse(R"([modbus]
mode = "rtu"
device = "/dev/ttyS1"
baud = 57600
parity = "E"
stop_bits = 2
slave = 17
response_timeout_ms = 5
retries = 2
inputs = ["velocity", "demand"]
outputs = ["command"]
)",
                    &c, &error))
      << error;
  EXPECT_EQ(c.io.modbus.mode, ModbusMode::kRtu);
  EXPECT_EQ(c.io.modbus.device, "/dev/ttyS1");
  EXPECT_EQ(c.io.modbus.baud, 57600);
  EXPECT_EQ(c.io.modbus.parity, 'E');
  EXPECT_EQ(c.io.modbus.stop_bits, 2);
  EXPECT_EQ(c.io.modbus.slave, 17);
  EXPECT_EQ(c.io.modbus.response_timeout_ns, 5'000'000);
  EXPECT_EQ(c.io.modbus.retries, 2);
}

TEST(IoConfigTest, MixedBusesServeDifferentSignals) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(Parse(R"([velocity]
source = "displacement"
[can]
interface = "can0"
inputs = ["demand"]
outputs = ["command", "heartbeat"]
[gpio]
chip = "gpiochip0"
inputs = ["displacement", "fault_line"]
outputs = ["enable", "heartbeat"]
encoder_a_line = 1
encoder_b_line = 2
fault_line = 3
enable_line = 4
heartbeat_line = 5
fault_active_low = true
counts_per_cm = 100
)",
                    &c, &error))
      << error;
  EXPECT_EQ(c.io.gpio.encoder_a_line, 1);
  EXPECT_EQ(c.io.gpio.heartbeat_line, 5);
  EXPECT_TRUE(c.io.gpio.fault_active_low);
  EXPECT_EQ(c.io.gpio.counts_per_cm, 100.0);
}

TEST(IoConfigTest, RefusesAnInputWithTwoSources) {
  const std::string e = ErrorOf(R"([can]
local_bus = "/tmp/b"
inputs = ["velocity", "demand"]
outputs = ["command"]
[modbus]
inputs = ["velocity"]
)");
  EXPECT_EQ(e, "fw.toml:6: input 'velocity' has two sources");
}

TEST(IoConfigTest, RefusesACommandDrivenByTwoBuses) {
  const std::string e = ErrorOf(R"([can]
local_bus = "/tmp/b"
inputs = ["velocity", "demand"]
outputs = ["command", "heartbeat"]
[modbus]
outputs = ["command", "heartbeat"]
)");
  EXPECT_EQ(e, "fw.toml:6: output 'command' is driven by two buses");
}

TEST(IoConfigTest, RefusesARequiredInputWithNoSource) {
  EXPECT_EQ(
      ErrorOf("[can]\nlocal_bus = \"/b\"\ninputs = [\"velocity\"]\noutputs = [\"command\"]\n"),
      "fw.toml: no bus serves input 'demand' (law \"force\")");
  EXPECT_EQ(ErrorOf("[control]\nlaw = \"skyhook\"\n[can]\nlocal_bus = \"/b\"\n"
                    "inputs = [\"velocity\"]\noutputs = [\"command\"]\n"),
            "fw.toml: no bus serves input 'body_velocity' (skyhook laws)");
  EXPECT_EQ(
      ErrorOf("[control]\nlaw = \"constant\"\n[velocity]\nsource = \"displacement\"\n"
              "[can]\nlocal_bus = \"/b\"\ninputs = [\"velocity\"]\noutputs = [\"command\"]\n"),
      "fw.toml: no bus serves input 'displacement' ([velocity] source = \"displacement\")");
}

TEST(IoConfigTest, RefusesNoCommandOutput) {
  EXPECT_EQ(ErrorOf("[can]\nlocal_bus = \"/b\"\ninputs = [\"velocity\", \"demand\"]\n"
                    "outputs = [\"status\"]\n"),
            "fw.toml: no bus drives the 'command' output (the current driver's set-point)");
}

TEST(IoConfigTest, RefusesUnknownAndRepeatedNames) {
  EXPECT_EQ(ErrorOf("[can]\nlocal_bus = \"/b\"\ninputs = [\"speed\"]\n"),
            "fw.toml:3: 'inputs' has 'speed'; allowed: velocity, displacement, demand, "
            "body_velocity, force, fault_line, body_acceleration, wheel_velocity, "
            "floor_acceleration_1, floor_acceleration_2, floor_acceleration_3");
  EXPECT_EQ(ErrorOf("[gpio]\nchip = \"c\"\ninputs = [\"velocity\"]\n"),
            "fw.toml:3: 'inputs' has 'velocity'; allowed: displacement, fault_line");
  EXPECT_EQ(ErrorOf("[can]\nlocal_bus = \"/b\"\noutputs = [\"command\", \"command\"]\n"),
            "fw.toml:3: 'outputs' names 'command' twice");
  EXPECT_EQ(ErrorOf("[can]\nlocal_bus = \"/b\"\nbitrate = 500000\n"),
            "fw.toml:3: unknown key 'bitrate' in [can]");
}

TEST(IoConfigTest, RefusesAmbiguousOrMissingEndpoints) {
  const std::string both = ErrorOf(R"([can]
interface = "can0"
local_bus = "/tmp/b"
inputs = ["velocity", "demand"]
outputs = ["command"]
)");
  EXPECT_EQ(both,
            "fw.toml:2: [can] needs exactly one of 'interface' (SocketCAN) and "
            "'local_bus' (socket path)");
  EXPECT_EQ(ErrorOf("[modbus]\nmode = \"rtu\"\ninputs = [\"velocity\", \"demand\"]\n"
                    "outputs = [\"command\"]\n"),
            "fw.toml:2: [modbus] mode \"rtu\" needs 'device'");
}

TEST(IoConfigTest, RefusesGpioLinesMissingOrShared) {
  const std::string base =
      "[can]\nlocal_bus = \"/b\"\ninputs = [\"velocity\", \"demand\"]\noutputs = [\"command\"]\n";
  EXPECT_EQ(ErrorOf(base + "[gpio]\nchip = \"c\"\noutputs = [\"enable\"]\n"),
            "fw.toml:5: [gpio] needs 'enable_line'");
  EXPECT_EQ(ErrorOf(base + "[gpio]\nchip = \"c\"\noutputs = [\"enable\", \"heartbeat\"]\n"
                           "enable_line = 3\nheartbeat_line = 3\n"),
            "fw.toml:8: [gpio] 'enable_line' and 'heartbeat_line' are the same line 3");
  EXPECT_EQ(ErrorOf(base + "[gpio]\nsim_chip = \"/s\"\nchip = \"c\"\noutputs = [\"enable\"]\n"
                           "enable_line = 1\n"),
            "fw.toml:7: [gpio] needs exactly one of 'chip' (libgpiod) and 'sim_chip' "
            "(simulated chip)");
}

TEST(IoConfigTest, RefusesABusSectionWithNothingRouted) {
  EXPECT_EQ(ErrorOf("[can]\nlocal_bus = \"/b\"\n"),
            "fw.toml:1: [can] serves no input and drives no output (give 'inputs' and/or "
            "'outputs')");
}

TEST(IoConfigTest, ShippedExamplesParse) {
  const std::filesystem::path dir = std::filesystem::path(MRD_SOURCE_DIR) / "firmware/examples";
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    platform::FirmwareConfig c;
    std::string error;
    EXPECT_TRUE(platform::LoadConfigFile(entry.path().string(), &c, &error)) << error;
    EXPECT_TRUE(c.io.any()) << entry.path();
    ++n;
  }
  EXPECT_GE(n, 4);
}

TEST(IoConfigTest, CanFaultResetIntervalAndItsCommandFrames) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(
      Parse("[can]\nlocal_bus = \"/tmp/b\"\ninputs = [\"velocity\", \"demand\"]\noutputs = "
            "[\"command\"]\n",
            &c, &error))
      << error;
  EXPECT_EQ(c.io.can.fault_reset_ns, 1'000'000'000);  // default 1000 ms
  ASSERT_TRUE(
      Parse("[can]\nlocal_bus = \"/tmp/b\"\ninputs = [\"velocity\", \"demand\"]\noutputs = "
            "[\"command\"]\nfault_reset_ms = 250\n",
            &c, &error))
      << error;
  EXPECT_EQ(c.io.can.fault_reset_ns, 250'000'000);
  const std::string low = ErrorOf(
      "[can]\nlocal_bus = \"/tmp/b\"\ninputs = [\"velocity\", \"demand\"]\noutputs = "
      "[\"command\"]\nfault_reset_ms = 50\n");
  EXPECT_EQ(low.rfind("fw.toml:5: ", 0), 0U) << low;
  // A profile mapping fault_reset (docs/mrd.dbc with a FaultReset bit in DriverCommand) needs
  // the command frames: refused when [can] routes neither command nor enable.
  const auto dir =
      std::filesystem::temp_directory_path() / ("mrd-fault-reset-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ifstream in(std::string(MRD_SOURCE_DIR) + "/docs/mrd.dbc");
  std::string dbc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string after = " SG_ SafeState : 18|1@1+ (1,0) [0|1] \"\" Driver\n";
  ASSERT_NE(dbc.find(after), std::string::npos);
  dbc.insert(dbc.find(after) + after.size(), " SG_ FaultReset : 19|1@1+ (1,0) [0|1] \"\" Driver\n");
  std::ofstream(dir / "d.dbc") << dbc;
  std::ofstream(dir / "p.toml") << "name = \"latching\"\ndbc = \"d.dbc\"\n[inputs]\n"
                                   "velocity = \"SensorMotion.Velocity\"\n"
                                   "demand = \"SensorForce.Demand\"\n"
                                   "driver_faults = \"DriverStatus.DriverFaults\"\n[outputs]\n"
                                   "safe = \"DriverCommand.SafeState\"\n"
                                   "heartbeat_safe = \"Heartbeat.HeartbeatSafe\"\n"
                                   "fault_reset = \"DriverCommand.FaultReset\"\n";
  const std::string head =
      "[can]\nlocal_bus = \"/tmp/b\"\nprofile = \"p.toml\"\n"
      "inputs = [\"velocity\", \"demand\"]\n";
  platform::FirmwareConfig ok;
  // The command on Modbus (its built-in map), the heartbeat on CAN.
  EXPECT_FALSE(
      platform::ParseConfig(head + "outputs = [\"heartbeat\"]\n[modbus]\nhost = \"127.0.0.1\"\n"
                                   "outputs = [\"command\"]\n",
                            (dir / "fw.toml").string(), &ok, &error));
  EXPECT_EQ(error.rfind((dir / "fw.toml").string() + ":3: ", 0), 0U) << error;
  EXPECT_NE(error.find("route 'command' or 'enable'"), std::string::npos) << error;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mrd::firmware
