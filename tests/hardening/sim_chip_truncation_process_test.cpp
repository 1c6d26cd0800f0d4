// Conformance (labels conformance, hardening, hil): the simulated GPIO chip file truncated
// while mrd-firmware and mrd-hil serve both have it mapped (a closed loop over the local CAN
// bus and the chip). Both used to die of SIGBUS; now both run to their end: the firmware
// reports a gpio_bus fault and ends in the safe state, the harness counts the cycles it could not
// use the chip (rejected). Causal checks only (no timing): the machine may be loaded.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
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

json Parse(const ChildProcess& p) {
  try {
    return json::parse(p.Stdout());
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what() << "\nstdout:\n" << p.Stdout() << "\nstderr:\n" << p.Stderr();
    return json::object();
  }
}

TEST(SimChipTruncationProcess, BothProcessesSurviveAndTheFirmwareGoesSafe) {
  const std::string dir = "/tmp/mrd-trunc-proc-" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string socket = dir + "/bus.sock", chip = dir + "/gpio.chip";
  const std::string config = dir + "/firmware.toml";
  std::ofstream(config) << "[control]\nlaw = \"force\"\n\n"
                        << "[can]\nlocal_bus = \"" << socket << "\"\n"
                        << "inputs = [\"velocity\", \"demand\", \"body_velocity\", \"force\"]\n"
                        << "outputs = [\"command\", \"status\"]\n\n"
                        << "[gpio]\nsim_chip = \"" << chip << "\"\n"
                        << "inputs = [\"displacement\", \"fault_line\"]\n"
                        << "outputs = [\"enable\", \"heartbeat\"]\n"
                        << "encoder_a_line = 4\nencoder_b_line = 5\nfault_line = 6\n"
                        << "enable_line = 17\nheartbeat_line = 18\n";
  ChildProcess hil({kBin + "/mrd-hil", "serve", "--port", "can=" + socket, "--port", "gpio=" + chip,
                    "--duration", "4", "--json"});
  ASSERT_TRUE(mrd::test::WaitForPath(socket, 20.0) && mrd::test::WaitForPath(chip, 20.0))
      << hil.Stderr();
  ChildProcess fw({kBin + "/mrd-firmware", "--config", config, "--duration", "3", "--json"});
  // Truncate once the firmware has mapped the chip and runs (its heartbeat line toggles).
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  ASSERT_TRUE(fw.running()) << fw.Stderr();
  ASSERT_EQ(truncate(chip.c_str(), 0), 0);
  const int fw_rc = fw.Wait(60.0);
  const int hil_rc = hil.Wait(60.0);
  EXPECT_LT(fw_rc, 128) << "mrd-firmware died of signal " << fw_rc - 128 << "\n" << fw.Stderr();
  EXPECT_GE(fw_rc, 0) << fw.Stderr();
  EXPECT_LT(hil_rc, 128) << "mrd-hil died of signal " << hil_rc - 128 << "\n" << hil.Stderr();
  EXPECT_GE(hil_rc, 0) << hil.Stderr();
  const json f = Parse(fw);
  ASSERT_TRUE(f.contains("watchdog")) << fw.Stdout();
  EXPECT_GE(f["watchdog"]["gpio_bus"]["trips"].get<double>(), 1.0) << f.dump();
  EXPECT_GT(f["devices"]["gpio"]["tx_failed"].get<double>(), 0.0) << f.dump();
  EXPECT_TRUE(f["final_safe_state"].get<bool>());
  const json h = Parse(hil);
  ASSERT_TRUE(h.contains("ports")) << hil.Stdout();
  EXPECT_GT(h["ports"]["gpio"]["rejected"].get<double>(), 0.0) << h.dump();  // damaged-chip cycles
  std::filesystem::remove_all(dir);
}

}  // namespace
