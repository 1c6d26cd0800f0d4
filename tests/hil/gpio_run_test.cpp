// Issue 10 (GPIO piece) and issue 12: `mrd-hil run` with a scenario's [gpio] lines next to
// CAN, on the build machine: lockstep over the local CAN bus, the encoder, fault line, enable
// and heartbeat on the simulated chip file. The virtual board runs the same scenario on
// SocketCAN and gpio-sim (tests/vboard).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrd/firmware/io/gpio/gpio_device.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/hil/run/run.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "run/run_gpio.hpp"
#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;
using nlohmann::json;

const std::string kBin = MRD_BIN_DIR;
const std::string kScenario = std::string(MRD_SOURCE_DIR) + "/hil/scenarios/vboard-can-gpio.toml";

struct HilResult {
  int status = -1;
  json j;
  std::string out, err;
};

HilResult Hil(std::vector<std::string> args) {
  args.insert(args.begin(), {kBin + "/mrd-hil", "run"});
  args.push_back("--json");
  ChildProcess p(args);
  HilResult r;
  r.status = p.Wait(90.0);
  r.out = p.Stdout();
  r.err = p.Stderr();
  r.j = json::parse(r.out, nullptr, false);
  if (r.j.is_discarded()) r.j = json::object();
  return r;
}

std::string TempDir(const std::string& name) {
  const std::string dir = "/tmp/mrd-hil-gpio-" + std::to_string(getpid()) + "-" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string Write(const std::string& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir + "/" + name) << text;
  return dir + "/" + name;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The closed loop with the encoder-driven velocity: the firmware counts every edge the plant
// wrote, tracks the force demand far better than either passive setting, goes safe on the
// fault line at once (enable low, safe commands) and drives again once it clears.
TEST(HilGpioRunTest, VboardScenarioLockstepLocalBusAndSimChip) {
  const std::string out = TempDir("run");
  const HilResult r = Hil({kScenario, "--out", out});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(r.j["pass"].get<bool>()) << r.j["failures"].dump();
  EXPECT_EQ(r.j["clock"], "lockstep");
  EXPECT_EQ(r.j["invariant_violations"], 0);
  EXPECT_EQ(r.j["command_timeouts"], 0);
  EXPECT_EQ(r.j["heartbeat_timeouts"], 0);
  // The firmware read displacement from the encoder, velocity from its derivative; enable and
  // heartbeat on GPIO, not CAN.
  const std::string config = ReadAll(out + "/firmware.toml");
  EXPECT_NE(config.find("source = \"displacement\""), std::string::npos) << config;
  EXPECT_NE(config.find("inputs = [\"demand\", \"body_velocity\", \"force\"]"), std::string::npos);
  EXPECT_NE(config.find("outputs = [\"command\", \"status\"]"), std::string::npos);
  EXPECT_NE(config.find("sim_chip = \"" + out + "/gpio.chip\""), std::string::npos);
  // Every encoder edge the plant wrote was counted by the firmware, none rejected or lost.
  const std::uint64_t edges = r.j["ports"]["gpio"]["published"].get<std::uint64_t>();
  const json& fw_gpio = r.j["firmware"]["summary"]["devices"]["gpio"];
  EXPECT_GT(edges, 3000U);  // 1 cm at 2 Hz for 2 s, 400 counts/cm: 6400
  EXPECT_EQ(fw_gpio["rx_ok"].get<std::uint64_t>(), edges);
  EXPECT_EQ(fw_gpio["rx_rejected"], 0);
  // Heartbeat toggles heard on the line: one per firmware tick.
  EXPECT_GE(r.j["ports"]["gpio"]["received"].get<std::uint64_t>(), 1990U);
  const json& t = r.j["tracking"];
  EXPECT_LT(t["error_reachable"].get<double>(), 0.25);
  EXPECT_LT(t["error_reachable"].get<double>(),
            0.4 * t["passive_off"]["error_reachable"].get<double>());
  ASSERT_EQ(r.j["faults"].size(), 1U);
  const json& f = r.j["faults"][0];
  EXPECT_EQ(f["kind"], "fault_line");
  EXPECT_TRUE(f["ok"].get<bool>()) << f.dump();
  EXPECT_LE(f["periods_to_detection"].get<int>(), 1);
  EXPECT_LE(f["detection_to_safe_periods"].get<int>(), 2);
  EXPECT_LE(f["periods_to_recovery"].get<int>(), 10);
  const json& wd = r.j["firmware"]["summary"]["watchdog"]["fault_line"];
  EXPECT_EQ(wd["trips"], 1);
  EXPECT_EQ(wd["periods"], 50);  // 50 ms asserted, 1 ms periods
  EXPECT_EQ(r.j["firmware"]["summary"]["clock"]["missed_grants"], 0);
  EXPECT_EQ(r.j["firmware"]["exit"], 0);
}

// Lockstep with GPIO stays deterministic: the edges of a step are settled before its grant.
TEST(HilGpioRunTest, LockstepWithGpioIsDeterministic) {
  const std::string a = TempDir("det-a"), b = TempDir("det-b");
  HilResult ra = Hil({kScenario, "--out", a});
  HilResult rb = Hil({kScenario, "--out", b});
  ASSERT_EQ(ra.status, 0) << ra.out << ra.err;
  ASSERT_EQ(rb.status, 0) << rb.out << rb.err;
  EXPECT_EQ(ReadAll(a + "/trace.csv"), ReadAll(b + "/trace.csv"));
  ra.j.erase("timing");
  rb.j.erase("timing");
  ra.j.erase("out");
  rb.j.erase("out");
  EXPECT_EQ(ra.j["tracking"].dump(), rb.j["tracking"].dump());
  EXPECT_EQ(ra.j["faults"].dump(), rb.j["faults"].dump());
}

// The settle time before a grant covers the firmware's edge horizon.
TEST(HilGpioRunTest, EdgeSettleExceedsTheFirmwaresHorizon) {
  EXPECT_GT(mrd::hil::kEdgeSettleSimChipNs, mrd::firmware::GpioDevice::kEdgeHorizonNs);
  EXPECT_GT(mrd::hil::kEdgeSettleGpioSimNs, mrd::firmware::GpioDevice::kEdgeHorizonNs);
}

// The generated configuration with [gpio] on a gpio-sim chip and a SocketCAN interface is
// accepted by the firmware's own parser.
TEST(HilGpioRunTest, GeneratedConfigForSocketCanAndLibgpiodParses) {
  mrd::hil::Scenario s;
  std::string error;
  ASSERT_TRUE(mrd::hil::LoadScenario(kScenario, &s, &error)) << error;
  const std::string text = mrd::hil::FirmwareConfigText(s, "can", true, "vcan0", "gpiochip0");
  EXPECT_NE(text.find("interface = \"vcan0\""), std::string::npos) << text;
  EXPECT_NE(text.find("chip = \"gpiochip0\""), std::string::npos) << text;
  EXPECT_EQ(text.find("local_bus"), std::string::npos) << text;
  const std::string dir = TempDir("cfg");
  const std::string path = Write(dir, "fw.toml", text);
  mrd::firmware::platform::FirmwareConfig cfg;
  ASSERT_TRUE(mrd::firmware::platform::LoadConfigFile(path, &cfg, &error)) << error << "\n" << text;
}

// Bad input: a fault_line fault without the line routed, --gpio-sim without [gpio],
// --can-interface on Modbus or with a path: clear errors, exit 2, nothing run.
TEST(HilGpioRunTest, BadGpioInputIsRefused) {
  const std::string dir = TempDir("bad");
  const std::string no_line = Write(dir, "no-line.toml",
                                    "duration_s = 1.0\n[gpio]\ninputs = [\"displacement\"]\n"
                                    "[[fault]]\nkind = \"fault_line\"\nat_s = 0.5\n");
  HilResult r = Hil({no_line, "--out", dir + "/o1"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no-line.toml:4: a fault_line fault needs [gpio]"), std::string::npos)
      << r.err;
  const std::string bad_list = Write(dir, "bad-list.toml", "[gpio]\ninputs = [\"velocity\"]\n");
  r = Hil({bad_list, "--out", dir + "/o2"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("bad-list.toml:2: 'inputs' accepts: displacement, fault_line"),
            std::string::npos)
      << r.err;
  const std::string plain = Write(dir, "plain.toml", "duration_s = 0.1\n");
  r = Hil({plain, "--gpio-sim", "/sys/kernel/config/gpio-sim/x", "--out", dir + "/o3"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("routes nothing over GPIO"), std::string::npos) << r.err;
  r = Hil({plain, "--transport", "modbus-tcp", "--can-interface", "vcan0", "--out", dir + "/o4"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--can-interface 'vcan0'"), std::string::npos) << r.err;
  r = Hil({plain, "--can-interface", "/tmp/x.sock", "--out", dir + "/o5"});
  EXPECT_EQ(r.status, 2);
  // A gpio-sim directory that is not a live device: could not run (1), with the reason.
  r = Hil({kScenario, "--gpio-sim", dir + "/nonexistent", "--out", dir + "/o6"});
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("bank0/chip_name: cannot read"), std::string::npos) << r.err;
}

}  // namespace
