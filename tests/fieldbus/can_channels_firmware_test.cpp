// mrd-firmware with four damper channels over one CAN bus (labels fieldbus, firmware, profile):
// the config names the four shipped canopen-corner profiles in [channels] can_profiles on one
// [can] local bus, [loop] clock = "grant"; the test owns the local bus relay and plays the four
// CANopen drives and sensor nodes (can_corners_peer.hpp). Each corner's command follows its own
// demand, the commands are bit-identical between a run and one where the firmware is stopped
// (SIGSTOP) for 150 ms mid-step, only channel 0's device sends the node's heartbeat, and the
// --json summary holds the four channels, each with its own device ("can", "can1", ...).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "can_corners_peer.hpp"
#include "host/test_util.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

using namespace corners;  // NOLINT: the vehicle's side of the test

struct FirmwareRun {
  std::vector<Step> steps;
  std::uint64_t heartbeats_of_node1 = 0;
  int status = -1;
  nlohmann::json summary;
  std::string error;
};

std::string Config(const std::string& bus) {
  std::string profiles;
  for (std::size_t i = 0; i < kCorners; ++i) {
    profiles += (i == 0 ? "\"" : ", \"") + CornerProfilePath(i) + "\"";
  }
  return "[loop]\nperiod_us = 1000\nclock = \"grant\"\ngrant_timeout_ms = 10000\n"
         "[control]\nlaw = \"force\"\n"
         "[channels]\ncount = 4\nfault_policy = \"all\"\ncan_profiles = [" +
         profiles +
         "]\n"
         "[can]\nlocal_bus = \"" +
         bus +
         "\"\ninputs = [\"velocity\", \"displacement\", \"demand\"]\n"
         "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";
}

// steps steps against mrd-firmware; stop_at > 0: SIGSTOP right after that step's frames,
// SIGCONT 150 ms later.
FirmwareRun RunFirmware(int steps, int stop_at) {
  FirmwareRun r;
  TempDir dir;
  RelayBus bus;
  const std::string cfg = dir.Write("car.toml", Config(bus.path()));
  const std::string out = dir.File("out.json"), err = dir.File("err.txt");
  const std::string command =
      "exec " + Bin("mrd-firmware") + " --config " + cfg + " --json > " + out + " 2> " + err;
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  std::array<std::shared_ptr<const profile::CanProfile>, kCorners> profiles;
  for (std::size_t i = 0; i < kCorners; ++i) profiles[i] = CornerProfile(i);
  Vehicle vehicle(profiles);
  int exited = -2;  // the child's status once it ended early
  const bool started = StartDrives(bus, vehicle, 4000, [&] {
    int st = 0;
    if (waitpid(pid, &st, WNOHANG) == pid) exited = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return exited != -2;
  });
  Scenario s;
  for (int k = 1; started && k <= steps; ++k) {
    Step step;
    if (k == stop_at) {
      // Stopped between the step's frames and its commands: they wait in the sockets.
      vehicle.Step(bus, k, s);
      kill(pid, SIGSTOP);
      std::this_thread::sleep_for(std::chrono::milliseconds(150));
      kill(pid, SIGCONT);
      r.error = AwaitCommands(bus, vehicle, k, &step, &r.heartbeats_of_node1);
    } else {
      r.error = PlayStep(bus, vehicle, k, s, &step, &r.heartbeats_of_node1);
    }
    if (!r.error.empty()) break;
    r.steps.push_back(step);
  }
  if (exited == -2) {
    kill(pid, SIGTERM);
    // The relay keeps forwarding (the shutdown's safe commands) while the firmware ends.
    std::vector<can_frame> got;
    for (int i = 0; i < 1000; ++i) {
      int st = 0;
      if (waitpid(pid, &st, WNOHANG) == pid) {
        exited = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
        break;
      }
      got.clear();
      bus.Poll(5, &got);
    }
    if (exited == -2) exited = ReapWithin(pid, 1.0);
  }
  r.status = exited;
  if (!started && r.error.empty()) r.error = "the drives were not all started";
  r.error += FileBytes(err);
  try {
    r.summary = nlohmann::json::parse(FileBytes(out));
  } catch (const std::exception& e) {
    r.error += std::string(" summary: ") + e.what();
  }
  return r;
}

TEST(CanChannelsFirmware, FourCornersInLockstepBitIdenticalWithTheFirmwareStopped150ms) {
  constexpr int kSteps = 300;
  const FirmwareRun a = RunFirmware(kSteps, 0);
  ASSERT_EQ(a.steps.size(), static_cast<std::size_t>(kSteps)) << a.error;
  EXPECT_EQ(a.status, 0) << a.error;
  // Each corner its own current: a larger demand, a larger current (away from a reversal,
  // the smallest above the passive force, the largest below E_max's 450 mA).
  int ordered = 0, moving = 0;
  for (int k = 20; k <= kSteps; ++k) {
    const Step& st = a.steps[static_cast<std::size_t>(k - 1)];
    if (st[0].current_ma <= 0.0 || st[3].current_ma >= 450.0 || std::fabs(Velocity(0, k)) < 1.0) {
      continue;
    }
    ++moving;
    if (st[0].current_ma < st[1].current_ma && st[1].current_ma < st[2].current_ma &&
        st[2].current_ma < st[3].current_ma) {
      ++ordered;
    }
  }
  EXPECT_GT(moving, 80);
  EXPECT_EQ(ordered, moving);
  // One node, one heartbeat (every 10 ms of granted time).
  EXPECT_GE(a.heartbeats_of_node1, static_cast<std::uint64_t>(kSteps / 10 - 1));
  EXPECT_LE(a.heartbeats_of_node1, static_cast<std::uint64_t>(kSteps / 10 + 1));
  // The summary: four channels, each on its own device.
  const nlohmann::json& j = a.summary;
  ASSERT_TRUE(j.contains("channels")) << j.dump();
  ASSERT_EQ(j["channels"].size(), kCorners);
  EXPECT_EQ(j["fault_policy"], "all");
  EXPECT_EQ(j["clock"]["mode"], "grant");
  EXPECT_EQ(j["clock"]["grants"], kSteps);
  const char* names[kCorners] = {"can", "can1", "can2", "can3"};
  for (std::size_t i = 0; i < kCorners; ++i) {
    const nlohmann::json& c = j["channels"][i];
    EXPECT_EQ(c["ticks"], kSteps) << i;
    EXPECT_EQ(c["device"]["name"], names[i]);
    EXPECT_GT(c["device"]["rx_ok"].get<std::uint64_t>(), 2U * kSteps) << i;
    EXPECT_EQ(c["device"]["read_fault_periods"], 0) << i;
    EXPECT_TRUE(j["devices"].contains(names[i])) << j["devices"].dump();
  }

  const FirmwareRun b = RunFirmware(kSteps, 150);
  ASSERT_EQ(b.steps.size(), a.steps.size()) << b.error;
  EXPECT_EQ(b.status, 0) << b.error;
  for (std::size_t k = 0; k < a.steps.size(); ++k) {
    ASSERT_TRUE(a.steps[k] == b.steps[k]) << "step " << k + 1 << " differs with the stop";
  }
}

}  // namespace
}  // namespace mrd::test
