// Process lifecycle in lockstep and under signals (label hil, conformance):
//  - a firmware on the grant clock with no harness stops after grant_timeout_ms (exit 1), it
//    does not run forever or tick safe periods;
//  - `mrd-hil run` on SIGTERM, SIGINT and SIGHUP forwards the signal to its firmware child,
//    reaps it, removes its temporary directory and exits 128 + the signal;
//  - a killed harness takes its firmware child with it (PR_SET_PDEATHSIG);
//  - `mrd-hil run --attach` with no firmware ends once after the start-up timeout, not once
//    per step.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;
using Clock = std::chrono::steady_clock;

// MRD_TEST_BIN_DIR runs the same checks against other builds (e.g. an older one).
const std::string kBin =
    std::getenv("MRD_TEST_BIN_DIR") != nullptr ? std::getenv("MRD_TEST_BIN_DIR") : MRD_BIN_DIR;
const std::string kScn = std::string(MRD_SOURCE_DIR) + "/hil/scenarios/";

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The first child of pid (from /proc), or -1.
pid_t FirstChild(pid_t pid) {
  const std::string kids =
      Slurp("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) + "/children");
  return kids.empty() ? -1 : static_cast<pid_t>(std::stol(kids));
}

// Waits up to timeout_s for the first child of pid; -1 when none appeared.
pid_t WaitForChild(pid_t pid, double timeout_s) {
  const auto until = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (Clock::now() < until) {
    const pid_t c = FirstChild(pid);
    if (c > 0) return c;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return -1;
}

// True while pid runs (a zombie or a vanished pid has ended).
bool Running(pid_t pid) {
  const std::string stat = Slurp("/proc/" + std::to_string(pid) + "/stat");
  if (stat.empty()) return false;
  const auto close_paren = stat.rfind(')');
  return close_paren != std::string::npos && close_paren + 2 < stat.size() &&
         stat[close_paren + 2] != 'Z' && stat[close_paren + 2] != 'X';
}

bool WaitEnded(pid_t pid, double timeout_s) {
  const auto until = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (Running(pid)) {
    if (Clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

// The --config argument of a running process (its temporary directory's firmware.toml).
std::string ConfigArg(pid_t pid) {
  const std::string cmdline = Slurp("/proc/" + std::to_string(pid) + "/cmdline");
  std::vector<std::string> args;
  std::string a;
  for (char c : cmdline) {
    if (c == '\0') {
      args.push_back(a);
      a.clear();
    } else {
      a += c;
    }
  }
  for (std::size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == "--config") return args[i + 1];
  }
  return "";
}

TEST(LockstepLifecycleTest, FirmwareOnTheGrantClockWithoutAHarnessStops) {
  const std::string dir = "/tmp/mrd-nogrant-" + std::to_string(getpid());
  mkdir(dir.c_str(), 0755);
  const std::string sock = dir + "/bus.sock";
  ChildProcess relay({kBin + "/mrd-canbus", "--socket", sock});
  ASSERT_TRUE(mrd::test::WaitForPath(sock, 10.0));
  const std::string cfg = dir + "/fw.toml";
  std::ofstream(cfg) << "[loop]\nclock = \"grant\"\ngrant_timeout_ms = 500\n[control]\n"
                        "law = \"force\"\n[can]\nlocal_bus = \""
                     << sock
                     << "\"\n"
                        "inputs = [\"velocity\", \"demand\"]\n"
                        "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";
  ChildProcess fw({kBin + "/mrd-firmware", "--config", cfg, "--duration", "0.2", "--json"});
  const int status = fw.Wait(20.0);  // -1: still running after 20 s (then killed)
  relay.Signal(SIGTERM);
  relay.Wait(5.0);
  EXPECT_EQ(status, 1) << fw.Stderr();
  EXPECT_NE(fw.Stderr().find("no time grant for 0.5 s"), std::string::npos) << fw.Stderr();
  EXPECT_NE(fw.Stdout().find("\"missed_grants\": 1"), std::string::npos) << fw.Stdout();
  EXPECT_NE(fw.Stdout().find("\"ticks\": 0,"), std::string::npos) << fw.Stdout();
  EXPECT_NE(fw.Stdout().find("\"final_safe_state\": true"), std::string::npos) << fw.Stdout();
  unlink(cfg.c_str());
  rmdir(dir.c_str());
}

// One signal: the harness stops its firmware child with the same signal, reaps it, removes
// its temporary directory and exits 128 + the signal.
void ExpectSignalEndsTheRunCleanly(int sig, const std::string& clock) {
  SCOPED_TRACE(std::string(strsignal(sig)) + ", " + clock);
  ChildProcess hil({kBin + "/mrd-hil", "run", kScn + "quarter-car-skyhook.toml", "--clock", clock});
  const pid_t fw = WaitForChild(hil.pid(), 20.0);
  ASSERT_GT(fw, 0) << hil.Stderr();
  std::string config;
  for (int i = 0; i < 2000 && config.empty(); ++i) {  // until the child has exec'd
    config = ConfigArg(fw);
    if (config.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_FALSE(config.empty());
  const std::string temp = config.substr(0, config.rfind('/'));
  ASSERT_EQ(temp.rfind("/tmp/mrd-hil-", 0), 0U) << temp;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // mid-run
  hil.Signal(sig);
  EXPECT_EQ(hil.Wait(20.0), 128 + sig) << hil.Stderr();
  EXPECT_TRUE(WaitEnded(fw, 5.0)) << "firmware child " << fw << " left running";
  if (Running(fw)) kill(fw, SIGKILL);
  struct stat st {};
  EXPECT_NE(stat(temp.c_str(), &st), 0) << temp << " left behind";
  EXPECT_NE(hil.Stderr().find("interrupted by"), std::string::npos) << hil.Stderr();
}

TEST(LockstepLifecycleTest, TermIntAndHupStopTheRunReapTheFirmwareAndCleanUp) {
  for (const int sig : {SIGTERM, SIGINT, SIGHUP}) {
    ExpectSignalEndsTheRunCleanly(sig, "lockstep");
  }
  ExpectSignalEndsTheRunCleanly(SIGTERM, "realtime");
}

TEST(LockstepLifecycleTest, AKilledHarnessTakesItsFirmwareWithIt) {
  ChildProcess hil(
      {kBin + "/mrd-hil", "run", kScn + "quarter-car-skyhook.toml", "--clock", "realtime"});
  const pid_t fw = WaitForChild(hil.pid(), 20.0);
  ASSERT_GT(fw, 0) << hil.Stderr();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  hil.Signal(SIGKILL);
  hil.Wait(10.0);
  EXPECT_TRUE(WaitEnded(fw, 10.0)) << "firmware " << fw << " outlived its harness";
  if (Running(fw)) kill(fw, SIGKILL);
}

TEST(LockstepLifecycleTest, AttachWithoutAFirmwareEndsOnceAfterTheStartUpTimeout) {
  const auto t0 = Clock::now();
  ChildProcess hil({kBin + "/mrd-hil", "run", kScn + "force-periodic.toml", "--attach",
                    "--startup-timeout", "1"});
  const int status = hil.Wait(60.0);  // 3000 steps: one timeout per step would take 50 min
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  EXPECT_EQ(status, 1) << hil.Stderr();
  EXPECT_NE(hil.Stderr().find("no firmware answered within the start-up timeout (1 s) at step 0"),
            std::string::npos)
      << hil.Stderr();
  EXPECT_LT(s, 60.0);
}

}  // namespace
