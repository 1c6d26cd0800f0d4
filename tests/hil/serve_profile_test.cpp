// `mrd-hil serve --profile`: the harness plays a device profile's driver and sensors in real
// time for a firmware started separately on the same profile (labels profile, fieldbus, hil).
// Count-based checks with wide margins: the machine may be loaded.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;
using nlohmann::json;

const std::string kBin = MRD_BIN_DIR;
const std::string kSource = MRD_SOURCE_DIR;
const std::string kTestDriver = kSource + "/tests/data/profiles/test-driver.toml";

std::string RunDir(const char* tag) {
  const std::string dir =
      "/tmp/mrd-serve-profile-" + std::string(tag) + "-" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

json Parse(const ChildProcess& p) {
  const json j = json::parse(p.Stdout(), nullptr, false);
  return j.is_discarded() ? json::object() : j;
}

TEST(ServeProfileTest, FirmwareAndHarnessCloseTheLoopInTheTestDriversMessages) {
  const std::string dir = RunDir("clean");
  const std::string socket = dir + "/bus.sock", config = dir + "/firmware.toml";
  std::ofstream(config) << "[control]\nlaw = \"force\"\n\n[can]\nlocal_bus = \"" << socket
                        << "\"\nprofile = \"" << kTestDriver
                        << "\"\ninputs = [\"velocity\", \"displacement\", \"demand\", \"force\"]\n"
                           "outputs = [\"command\", \"enable\", \"heartbeat\"]\n";
  ChildProcess hil({kBin + "/mrd-hil", "serve", "--port", "can=" + socket, "--profile", kTestDriver,
                    "--duration", "4", "--json"});
  ASSERT_TRUE(mrd::test::WaitForPath(socket, 10.0)) << hil.Stderr();
  ChildProcess fw({kBin + "/mrd-firmware", "--config", config, "--duration", "3", "--json"});
  ASSERT_EQ(fw.Wait(30.0), 0) << fw.Stdout() << fw.Stderr();
  ASSERT_EQ(hil.Wait(30.0), 0) << hil.Stderr();
  const json f = Parse(fw), h = Parse(hil);
  ASSERT_TRUE(f.contains("devices") && h.contains("commands")) << f.dump() << h.dump();
  // The firmware understood the harness's frames (sensor frames every step) and the harness
  // the firmware's set-point (amps through the coil curve) without a violation.
  EXPECT_GT(f["devices"]["can"]["rx_ok"].get<long long>(), 1000) << f.dump();
  EXPECT_EQ(f["devices"]["can"]["rx_rejected"], 0) << f.dump();
  EXPECT_GT(h["commands"].get<long long>(), 1000) << h.dump();
  EXPECT_EQ(h["invariant_violations"], 0) << h.dump();
  std::filesystem::remove_all(dir);
}

TEST(ServeProfileTest, FirmwareAndHarnessCloseTheLoopOnTheModbusFloat32Map) {
  const std::string dir = RunDir("modbus");
  const std::string profile = kSource + "/firmware/profiles/modbus-float32.toml";
  const int port = 20000 + static_cast<int>(getpid() % 20000) + 3;
  const std::string config = dir + "/firmware.toml";
  std::ofstream(config) << "[control]\nlaw = \"force\"\n[safety]\nmax_age_ms = 20\n\n[modbus]\n"
                           "host = \"127.0.0.1\"\nport = "
                        << port << "\nprofile = \"" << profile
                        << "\"\ninputs = [\"velocity\", \"displacement\", \"demand\"]\n"
                           "outputs = [\"command\", \"enable\", \"heartbeat\"]\n";
  ChildProcess hil({kBin + "/mrd-hil", "serve", "--port",
                    "modbus-tcp=127.0.0.1:" + std::to_string(port), "--profile", profile,
                    "--duration", "4", "--json"});
  ASSERT_TRUE(mrd::test::TcpReady(port, 10.0)) << hil.Stderr();
  ChildProcess fw({kBin + "/mrd-firmware", "--config", config, "--duration", "3", "--json"});
  ASSERT_EQ(fw.Wait(30.0), 0) << fw.Stdout() << fw.Stderr();
  ASSERT_EQ(hil.Wait(30.0), 0) << hil.Stderr();
  const json f = Parse(fw), h = Parse(hil);
  ASSERT_TRUE(f.contains("devices") && h.contains("commands")) << f.dump() << h.dump();
  // The firmware read the harness's float32 registers and the harness heard its set-point.
  EXPECT_GT(h["commands"].get<long long>(), 500) << h.dump();
  EXPECT_EQ(h["invariant_violations"], 0) << h.dump();
  EXPECT_EQ(f["devices"]["modbus"]["rx_rejected"], 0) << f.dump();
  std::filesystem::remove_all(dir);
}

TEST(ServeProfileTest, ABadProfileIsRefusedWithFileAndLine) {
  const std::string dir = RunDir("bad");
  const std::string bad = dir + "/bad.toml";
  std::ofstream(bad) << "name = \"bad\"\ndbc = \"" << kSource
                     << "/tests/data/profiles/test-driver.dbc\"\n[inputs]\n"
                        "velocity = \"NoSuchMessage.Speed\"\n";
  ChildProcess hil({kBin + "/mrd-hil", "serve", "--port", "can=" + dir + "/bus.sock", "--profile",
                    bad, "--duration", "1"});
  EXPECT_EQ(hil.Wait(30.0), 2);
  EXPECT_NE(hil.Stderr().find("bad.toml:4: inputs.velocity"), std::string::npos) << hil.Stderr();
  EXPECT_FALSE(std::filesystem::exists(dir + "/bus.sock"));
  std::filesystem::remove_all(dir);
}

}  // namespace
