// mrd-firmware stops promptly on SIGTERM whatever its Modbus peer does: with a silent peer,
// response_timeout_ms = 2000 and retries = 10, the worker abandons its wait at the stop
// request and the shutdown's one safe write waits one response timeout at most
// (docs/modbus_registers.md: the stop takes at most one response timeout plus a few ms).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "modbus_raw_peer.hpp"
#include "modbus_test_peers.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

TEST(ModbusShutdownTest, SigtermWithASilentPeerStopsWithinOneResponseTimeout) {
  const int port = FreeTcpPort();
  RawPeerScript script;
  script.silent = true;
  RawTcpPeer peer(port, script);
  ASSERT_TRUE(peer.listening());
  const std::string dir = "/tmp/mrd-modbus-stop-" + std::to_string(getpid());
  ASSERT_EQ(system(("mkdir -p " + dir).c_str()), 0);
  {
    std::ofstream cfg(dir + "/fw.toml");
    cfg << "[control]\nlaw = \"force\"\n\n[modbus]\nmode = \"tcp\"\nhost = \"127.0.0.1\"\n"
        << "port = " << port << "\nresponse_timeout_ms = 2000\nretries = 10\n"
        << "inputs = [\"velocity\", \"displacement\", \"demand\"]\n"
        << "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";
  }
  ChildProcess fw(
      {std::string(MRD_BIN_DIR) + "/mrd-firmware", "--config", dir + "/fw.toml", "--json"});
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (peer.requests() < 1 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_GE(peer.requests(), 1) << fw.Stderr();  // a request waits for its reply
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto t0 = std::chrono::steady_clock::now();
  fw.Signal(SIGTERM);
  // One response timeout (2 s) for the final safe write, plus slack for a loaded machine;
  // the retry loop that ignored the stop took 21 s.
  const int status = fw.Wait(8.0);
  const double stop_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  (void)system(("rm -rf " + dir).c_str());
  ASSERT_NE(status, -1) << "still running 8 s after SIGTERM";
  std::printf("SIGTERM to exit: %.2f s (response_timeout_ms = 2000, retries = 10)\n", stop_s);
  const nlohmann::json j = nlohmann::json::parse(fw.Stdout(), nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << fw.Stdout() << fw.Stderr();
  EXPECT_TRUE(j["final_safe_state"].get<bool>());
  EXPECT_GT(j["devices"]["modbus"]["errors"]["timeout"].get<std::uint64_t>(), 0U);
}

}  // namespace
}  // namespace mrd::test
