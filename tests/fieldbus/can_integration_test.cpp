// mrd-firmware as its own process against mrd-hil serve over the local CAN bus: the loop
// closes on the simulated damper for a few seconds (counters checked), and survives the
// harness going away and coming back (watchdog on the CAN cause and stale data, recovery).
// Count-based checks with wide margins: the machine may be loaded.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;
using nlohmann::json;

const std::string kBin = MRD_BIN_DIR;

struct RunFiles {
  std::string dir, socket, config;
};

RunFiles MakeRunFiles(const char* tag) {
  RunFiles s;
  s.dir = "/tmp/mrd-can-it-" + std::string(tag) + "-" + std::to_string(getpid());
  std::filesystem::create_directories(s.dir);
  s.socket = s.dir + "/bus.sock";
  std::filesystem::remove(s.socket);
  s.config = s.dir + "/firmware.toml";
  std::ofstream(s.config) << "[control]\nlaw = \"force\"\n\n[can]\n"
                             "inputs = [\"velocity\", \"displacement\", \"demand\", "
                             "\"body_velocity\", \"force\"]\n"
                             "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n"
                             "local_bus = \""
                          << s.socket << "\"\n";
  return s;
}

json Parse(const ChildProcess& p, const char* who) {
  try {
    return json::parse(p.Stdout());
  } catch (const std::exception& e) {
    ADD_FAILURE() << who << ": " << e.what() << "\nstdout:\n"
                  << p.Stdout() << "\nstderr:\n"
                  << p.Stderr();
    return json::object();
  }
}

ChildProcess Hil(const RunFiles& s, double seconds) {
  return ChildProcess({kBin + "/mrd-hil", "serve", "--port", "can=" + s.socket, "--duration",
                       std::to_string(seconds), "--json", "--rt-priority", "70"});
}

ChildProcess Firmware(const RunFiles& s, double seconds) {
  return ChildProcess({kBin + "/mrd-firmware", "--config", s.config, "--duration",
                       std::to_string(seconds), "--json"});
}

TEST(CanIntegration, FirmwareClosesTheLoopOverTheLocalCanBus) {
  const RunFiles s = MakeRunFiles("clean");
  ChildProcess hil = Hil(s, 4.0);
  ASSERT_TRUE(mrd::test::WaitForPath(s.socket, 10.0)) << hil.Stderr();
  ChildProcess fw = Firmware(s, 3.0);
  ASSERT_EQ(fw.Wait(30.0), 0) << fw.Stdout() << fw.Stderr();
  ASSERT_EQ(hil.Wait(30.0), 0) << hil.Stderr();
  const json f = Parse(fw, "mrd-firmware");
  const json h = Parse(hil, "mrd-hil");
  ASSERT_TRUE(f.contains("devices") && h.contains("ports")) << f.dump() << h.dump();
  std::fprintf(stderr, "firmware: %s\nhil: %s\n", f.dump().c_str(), h.dump().c_str());

  const json& can = f["devices"]["can"];
  EXPECT_GT(can["rx_ok"].get<int>(), 2000);  // two sensor frames per harness step
  EXPECT_EQ(can["rx_rejected"].get<int>(), 0);
  EXPECT_EQ(can["reconnects"].get<int>(), 0);
  const auto ticks = f["ticks"].get<long>();
  // Every period of the 3 s at 1 kHz was run or counted missed, most of them run.
  EXPECT_GE(ticks + f["missed_periods"].get<long>(), 2990);
  EXPECT_GT(ticks, 1500);
  // A command every period (and heartbeats, status): every tick sent or counted its failure.
  EXPECT_GE(can["tx_ok"].get<long>() + can["tx_failed"].get<long>(), ticks);
  // Overruns happen on a loaded VM; the bus work must not make them the rule.
  EXPECT_LT(f["overruns"].get<long>(), ticks / 10);
  EXPECT_LT(f["safe_periods"].get<long>(), ticks / 4);  // left the safe state
  EXPECT_EQ(f["watchdog"]["can_bus"]["trips"].get<int>(), 0);
  EXPECT_TRUE(f["final_safe_state"].get<bool>());

  EXPECT_EQ(h["invariant_violations"].get<int>(), 0);
  EXPECT_GT(h["commands"].get<int>(), 1000);
  EXPECT_GT(h["enabled_steps"].get<int>(), 1000);
  EXPECT_GT(h["latency_us"]["count"].get<int>(), 1000);
  EXPECT_EQ(h["ports"]["can"]["rejected"].get<int>(), 0);
  EXPECT_GT(h["ports"]["can"]["published"].get<int>(), 3000);
  // After the firmware stopped, the driver sat at 0 V.
  EXPECT_DOUBLE_EQ(h["last_applied_v"].get<double>(), 0.0);
}

TEST(CanIntegration, FirmwareSurvivesTheHarnessLeavingAndComingBack) {
  const RunFiles s = MakeRunFiles("restart");
  ChildProcess hil1 = Hil(s, 1.5);
  ASSERT_TRUE(mrd::test::WaitForPath(s.socket, 10.0)) << hil1.Stderr();
  constexpr double kFirmwareSeconds = 4.5;
  ChildProcess fw = Firmware(s, kFirmwareSeconds);
  ASSERT_EQ(hil1.Wait(30.0), 0) << hil1.Stderr();  // the bus goes with it
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_TRUE(fw.running()) << fw.Stdout() << fw.Stderr();
  ChildProcess hil2 = Hil(s, 2.0);
  ASSERT_EQ(fw.Wait(30.0), 0) << fw.Stdout() << fw.Stderr();
  ASSERT_EQ(hil2.Wait(30.0), 0) << hil2.Stderr();
  const json f = Parse(fw, "mrd-firmware");
  const json h1 = Parse(hil1, "mrd-hil (first)");
  const json h2 = Parse(hil2, "mrd-hil (second)");
  ASSERT_TRUE(f.contains("devices") && h1.contains("ports") && h2.contains("ports"));
  std::fprintf(stderr, "firmware: %s\nhil1: %s\nhil2: %s\n", f.dump().c_str(), h1.dump().c_str(),
               h2.dump().c_str());

  // The loss shows on the CAN cause and as stale data; the device reconnected.
  EXPECT_GE(f["watchdog"]["can_bus"]["trips"].get<int>(), 1);
  EXPECT_GE(f["watchdog"]["stale_sensor"]["trips"].get<int>(), 1);
  EXPECT_GE(f["devices"]["can"]["errors"]["disconnected"].get<int>(), 1);
  EXPECT_GE(f["devices"]["can"]["reconnects"].get<int>(), 1);
  // The loop kept its period throughout: every period was run or counted as missed.
  const auto ticks = f["ticks"].get<long>();
  const auto missed = f["missed_periods"].get<long>();
  EXPECT_GT(ticks + missed, static_cast<long>(0.9 * kFirmwareSeconds * 1000));
  EXPECT_GT(f["safe_periods"].get<long>(), 300);  // at least the gap between the harnesses
  EXPECT_LT(f["safe_periods"].get<long>(), ticks - 1000);
  EXPECT_TRUE(f["final_safe_state"].get<bool>());
  // Both harness runs saw commands within range, and the coil driven: before the loss and
  // again after the recovery.
  for (const json* h : {&h1, &h2}) {
    EXPECT_EQ((*h)["invariant_violations"].get<int>(), 0);
    EXPECT_GT((*h)["commands"].get<int>(), 300);
    EXPECT_GT((*h)["enabled_steps"].get<int>(), 300);
    EXPECT_GT((*h)["latency_us"]["count"].get<int>(), 300);
  }
}

}  // namespace

namespace {

TEST(CanbusCli, BadArgumentsAreRefusedWithExit2) {
  for (const std::vector<std::string>& args : {std::vector<std::string>{},
                                               {"--socket"},
                                               {"--frobnicate"},
                                               {"--socket", "/tmp/x.sock", "--duration", "soon"},
                                               {"--socket", "/tmp/x.sock", "--duration", "-1"}}) {
    std::vector<std::string> argv{kBin + "/mrd-canbus"};
    argv.insert(argv.end(), args.begin(), args.end());
    ChildProcess p(argv);
    EXPECT_EQ(p.Wait(10.0), 2) << p.Stderr();
    EXPECT_EQ(p.Stderr().rfind("error: ", 0), 0U) << p.Stderr();
  }
  ChildProcess p(
      {kBin + "/mrd-canbus", "--socket", "/nonexistent-dir/bus.sock", "--duration", "1"});
  EXPECT_EQ(p.Wait(10.0), 1);
  EXPECT_NE(p.Stderr().find("cannot listen on /nonexistent-dir/bus.sock"), std::string::npos)
      << p.Stderr();
}

// The stand-alone relay carries the firmware and the harness (the harness then joins the
// bus instead of owning it).
TEST(CanbusCli, StandAloneRelayCarriesTheLoop) {
  const RunFiles s = MakeRunFiles("relay");
  ChildProcess relay({kBin + "/mrd-canbus", "--socket", s.socket, "--duration", "4"});
  ASSERT_TRUE(mrd::test::WaitForPath(s.socket, 10.0)) << relay.Stderr();
  ChildProcess hil = Hil(s, 2.5);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ChildProcess fw = Firmware(s, 2.0);
  ASSERT_EQ(fw.Wait(30.0), 0) << fw.Stderr();
  ASSERT_EQ(hil.Wait(30.0), 0) << hil.Stderr();
  ASSERT_EQ(relay.Wait(30.0), 0) << relay.Stderr();
  const json r = Parse(relay, "mrd-canbus");
  const json h = Parse(hil, "mrd-hil");
  const json f = Parse(fw, "mrd-firmware");
  ASSERT_TRUE(r.contains("frames_in") && h.contains("ports") && f.contains("devices"));
  EXPECT_EQ(r["nodes_joined"].get<int>(), 2);
  EXPECT_EQ(r["bad_packets"].get<int>(), 0);
  EXPECT_GT(r["frames_in"].get<int>(), 4000);
  EXPECT_GT(f["devices"]["can"]["rx_ok"].get<int>(), 1500);
  EXPECT_EQ(f["devices"]["can"]["rx_rejected"].get<int>(), 0);
  EXPECT_EQ(h["invariant_violations"].get<int>(), 0);
  EXPECT_GT(h["enabled_steps"].get<int>(), 500);
}

}  // namespace
