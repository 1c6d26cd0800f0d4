// Four damper channels over one CAN bus in lockstep (labels fieldbus, profile): the firmware's
// side in-process as mrd-firmware builds it for [channels] can_profiles (a CanDevice per corner
// with the shipped canopen-corner profiles, each on its own node of an in-process local frame
// bus relay; its FieldbusIo, controller, telemetry; one Loop on channel 0's GrantClock, the
// other devices followers) on a thread, and the test playing the four CANopen drives (SDO
// answers, NMT start, heartbeats, status TPDOs) and the four sensor nodes with the profiles'
// codecs: per step each corner's sensor frames, then one grant, then the four commands awaited.
//   - each corner's command follows its own demand (a larger demand, a larger current);
//   - the run is bit-identical on repeat, and when the grant reaches the followers late (a
//     relay that hands a step to channel 0's node, then, 2 ms later, to the others; once 150
//     ms later): a follower never reads a previous tick's sample;
//   - a corner whose sensor frames stop: under fault policy "all" every channel commands its
//     safe value within 2 periods, under "channel" the other three keep commanding; counted per
//     channel;
//   - the loop thread allocates nothing once running (the executable replaces the allocator).
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "can_corners_peer.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/canopen_codec.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "support/alloc_counter.hpp"  // replaces the allocator of this executable
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

namespace pf = profile;
using namespace test::corners;  // NOLINT: the vehicle's side of the test

constexpr std::int64_t kPeriod = 1'000'000;  // [ns]
// The demo table's E_max (2.25 V) through canopen-coil.csv (200 mA/V) [mA].
constexpr double kMaxCurrentMa = 450.0;

// A bus that hands each step to channel 0's node first and to the others delay later (one
// socketpair per node; the nodes do not hear each other): the relay's hand-over, one node after
// another, stretched so that channel 0 always wakes before the followers have their frames.
class LateFollowersBus final : public Bus {
 public:
  LateFollowersBus(int delay_ms, int long_step, int long_delay_ms)
      : delay_ms_(delay_ms), long_step_(long_step), long_delay_ms_(long_delay_ms) {
    for (std::size_t i = 0; i < kCorners; ++i) {
      int sv[2];
      EXPECT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
      device_fd_[i] = sv[0];
      peer_[i] = sv[1];
    }
  }
  ~LateFollowersBus() override {
    for (const int fd : peer_) close(fd);
  }
  // The device end of node i (the device takes it).
  int device_fd(std::size_t i) const { return device_fd_[i]; }
  void Send(const can_frame& f) override {
    if (in_step_) {
      step_.push_back(f);
      return;
    }
    for (const int fd : peer_) (void)write(fd, &f, sizeof f);
  }
  void BeginStep(int step) override {
    in_step_ = true;
    step_no_ = step;
    step_.clear();
  }
  void EndStep() override {
    in_step_ = false;
    for (const can_frame& f : step_) (void)write(peer_[0], &f, sizeof f);
    std::this_thread::sleep_for(
        std::chrono::milliseconds(step_no_ == long_step_ ? long_delay_ms_ : delay_ms_));
    for (std::size_t i = 1; i < kCorners; ++i) {
      for (const can_frame& f : step_) (void)write(peer_[i], &f, sizeof f);
    }
  }
  void Poll(int timeout_ms, std::vector<can_frame>* got) override {
    std::array<pollfd, kCorners> p{};
    for (std::size_t i = 0; i < kCorners; ++i) p[i] = {peer_[i], POLLIN, 0};
    if (poll(p.data(), p.size(), timeout_ms) <= 0) return;
    for (std::size_t i = 0; i < kCorners; ++i) {
      if ((p[i].revents & POLLIN) == 0) continue;
      char packet[64];
      while (recv(peer_[i], packet, sizeof packet, MSG_DONTWAIT) >= 16) {
        can_frame f{};
        std::memcpy(&f, packet, sizeof f);
        got->push_back(f);
      }
    }
  }

 private:
  int delay_ms_, long_step_, long_delay_ms_;
  std::array<int, kCorners> device_fd_{}, peer_{};
  bool in_step_ = false;
  int step_no_ = 0;
  std::vector<can_frame> step_;
};

// What the firmware side runs: a device, I/O, controller and telemetry per corner, the loop.
struct Firmware {
  Firmware(FaultPolicy fault_policy,
           const std::array<std::shared_ptr<const pf::CanProfile>, 4>& profiles,
           const std::string& local_bus, const LateFollowersBus* pairs)
      : policy(fault_policy) {
    for (std::size_t i = 0; i < kCorners; ++i) {
      CanConfig c;
      c.enabled = true;
      c.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand);
      c.outputs = Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat);
      c.local_bus = local_bus;
      c.can_profile = profiles[i];
      c.period_ns = kPeriod;
      c.lockstep = true;
      // As bus_channels.cpp sets them.
      c.node_frames = i == 0;
      c.grant_follower = i != 0;
      c.follower_wait_ns = 5'000'000'000;
      devices[i] = pairs != nullptr ? std::make_unique<CanDevice>(c, pairs->device_fd(i))
                                    : std::make_unique<CanDevice>(c);
      EXPECT_TRUE(io[i].Add(devices[i].get()));
      ControllerConfig k;
      k.law.mode = ControlMode::kForceTracking;
      EXPECT_EQ(controllers[i].Configure(test::DemoDamperTable(), k), Error::kOk);
      channels[i] = std::make_unique<Channel>(io[i], io[i], controllers[i], telemetry[i]);
    }
  }
  // The thread's body: every device started in channel order, then the loop until stop.
  void Run() {
    loop_tid = gettid();
    for (auto& d : devices) {
      std::string error;
      if (!d->Configure(&error) || !d->Activate(&error)) {
        start_error = error;
        failed = true;
        return;
      }
    }
    GrantClock clock(*devices[0], 5'000'000'000, &stop);
    std::array<Channel*, kCorners> list{};
    for (std::size_t i = 0; i < kCorners; ++i) list[i] = channels[i].get();
    Loop loop(clock, list.data(), kCorners, policy, kPeriod);
    started = true;
    loop.Run(stop, 0);
    grants = clock.grants();
  }

  FaultPolicy policy;
  std::array<std::unique_ptr<CanDevice>, kCorners> devices;
  std::array<FieldbusIo, kCorners> io;
  std::array<Controller, kCorners> controllers;
  std::array<Telemetry, kCorners> telemetry;
  std::array<std::unique_ptr<Channel>, kCorners> channels;
  std::atomic<bool> stop{false};
  std::atomic<bool> started{false};
  std::atomic<bool> failed{false};  // start_error says why (read after the join)
  std::atomic<pid_t> loop_tid{0};
  std::string start_error;
  std::uint64_t grants = 0;
};

struct Result {
  std::vector<Step> steps;
  std::array<TelemetrySnapshot, kCorners> stats;
  std::array<DeviceCounters, kCorners> counters;
  std::uint64_t heartbeats_of_node1 = 0;  // the firmware's CANopen heartbeat (0x701)
  std::uint64_t loop_allocations = 0;
  std::string error;
};

Result RunVehicle(const Scenario& s) {
  Result r;
  std::array<std::shared_ptr<const pf::CanProfile>, 4> profiles;
  for (std::size_t i = 0; i < kCorners; ++i) profiles[i] = CornerProfile(i);
  std::unique_ptr<RelayBus> relay;
  std::unique_ptr<LateFollowersBus> pairs;
  if (s.late_ms >= 0) {
    pairs = std::make_unique<LateFollowersBus>(2, 100, s.late_ms);
  } else {
    relay = std::make_unique<RelayBus>();
  }
  Bus& bus = relay ? static_cast<Bus&>(*relay) : *pairs;
  Firmware fw(s.policy, profiles, relay ? relay->path() : "", pairs.get());
  Vehicle vehicle(profiles);
  std::thread thread([&] { fw.Run(); });
  // Start-up: every drive configured and started (within 10 s of wall time).
  const bool all_started = StartDrives(bus, vehicle, 2000, [&] { return fw.failed.load(); });
  std::vector<can_frame> got;
  while (all_started && !fw.started.load() && !fw.failed.load()) {
    got.clear();
    bus.Poll(1, &got);
  }
  std::unique_ptr<test::ThreadAllocationGuard> guard;
  for (int k = 1; all_started && k <= s.steps; ++k) {
    if (k == 50) guard = std::make_unique<test::ThreadAllocationGuard>();
    Step step;
    r.error = PlayStep(bus, vehicle, k, s, &step, &r.heartbeats_of_node1);
    if (!r.error.empty()) break;
    r.steps.push_back(step);
  }
  if (guard) {
    guard->Stop();
    r.loop_allocations = guard->CountOn(fw.loop_tid.load());
    if (r.loop_allocations != 0) r.error += guard->Report();
  }
  fw.stop.store(true);
  thread.join();
  if (!fw.start_error.empty()) r.error = "start: " + fw.start_error;
  if (!all_started && r.error.empty()) r.error = "the drives were not all started";
  for (std::size_t i = 0; i < kCorners; ++i) {
    r.stats[i] = fw.telemetry[i].Read();
    r.counters[i] = fw.devices[i]->counters();
  }
  return r;
}

std::size_t Trips(const TelemetrySnapshot& s, FaultCause c) {
  return s.watchdog.trips[static_cast<std::size_t>(c)];
}

TEST(CanChannelsLockstep, EachCornerFollowsItsOwnSensorsBitIdenticalOnRepeat) {
  const Scenario s;
  const Result a = RunVehicle(s);
  ASSERT_EQ(a.error, "");
  ASSERT_EQ(a.steps.size(), static_cast<std::size_t>(s.steps));
  // Each corner commands from its own demand: in every step where even the smallest demand
  // (corner 0's) asks for current beyond the passive damper's and the largest is not clipped
  // at E_max and the velocity is not about to reverse, a corner with a larger demand gets a
  // larger current.
  int ordered = 0, moving = 0;
  for (int k = 20; k < s.steps; ++k) {
    const Step& st = a.steps[static_cast<std::size_t>(k - 1)];
    bool all_enabled = true;
    for (const Command& c : st) all_enabled = all_enabled && c.enable == 1.0;
    EXPECT_TRUE(all_enabled) << "step " << k;
    if (st[0].current_ma <= 0.0 || st[3].current_ma >= kMaxCurrentMa ||
        std::fabs(Velocity(0, k)) < 1.0) {
      continue;
    }
    ++moving;
    if (st[0].current_ma < st[1].current_ma && st[1].current_ma < st[2].current_ma &&
        st[2].current_ma < st[3].current_ma) {
      ++ordered;
    }
  }
  EXPECT_GT(moving, 100);
  EXPECT_EQ(ordered, moving);
  for (std::size_t i = 0; i < kCorners; ++i) {
    EXPECT_EQ(a.stats[i].ticks, static_cast<std::uint64_t>(s.steps)) << "corner " << i;
    EXPECT_EQ(a.stats[i].read_faults, 0U) << "corner " << i;
  }
  // One node, one heartbeat: only channel 0's device produces 0x701 (every 10 ms).
  EXPECT_GE(a.heartbeats_of_node1, static_cast<std::uint64_t>(s.steps / 10 - 1));
  EXPECT_LE(a.heartbeats_of_node1, static_cast<std::uint64_t>(s.steps / 10 + 1));
  EXPECT_EQ(a.loop_allocations, 0U);

  const Result b = RunVehicle(s);
  ASSERT_EQ(b.error, "");
  ASSERT_EQ(b.steps.size(), a.steps.size());
  for (std::size_t k = 0; k < a.steps.size(); ++k) {
    ASSERT_TRUE(a.steps[k] == b.steps[k]) << "step " << k + 1 << " differs on repeat";
  }
}

// The followers get each step 2 ms after channel 0 (once 150 ms: the followers' node stalled):
// they wait for their own grant, so every command equals the prompt relay's bit for bit.
TEST(CanChannelsLockstep, FollowersNeverReadAPreviousTicksSample) {
  Scenario prompt;
  prompt.steps = 200;
  const Result a = RunVehicle(prompt);
  ASSERT_EQ(a.error, "");
  Scenario late = prompt;
  late.late_ms = 150;
  const Result b = RunVehicle(late);
  ASSERT_EQ(b.error, "");
  ASSERT_EQ(b.steps.size(), a.steps.size());
  int differing = 0;
  for (std::size_t k = 0; k < a.steps.size(); ++k) {
    if (!(a.steps[k] == b.steps[k])) ++differing;
  }
  EXPECT_EQ(differing, 0) << "steps where a follower read a previous tick's sample";
  for (std::size_t i = 0; i < kCorners; ++i) {
    EXPECT_EQ(b.stats[i].read_faults, 0U) << "corner " << i;
  }
}

// Corner 2's sensor node falls silent at step 200: its samples go stale (its own cause).
TEST(CanChannelsLockstep, OneCornerFaultsPolicyAllPutsEveryChannelSafeWithinTwoPeriods) {
  Scenario s;
  s.silent_corner = 2;
  s.silent_from = 200;
  const Result r = RunVehicle(s);
  ASSERT_EQ(r.error, "");
  int first_safe = -1;
  for (int k = 200; k <= s.steps && first_safe < 0; ++k) {
    if (r.steps[static_cast<std::size_t>(k - 1)][2].enable == 0.0) first_safe = k;
  }
  ASSERT_GT(first_safe, 0) << "corner 2 never went safe";
  // The others one period later (the loop's rule), within the 2 periods asked.
  for (int k = first_safe + 1; k <= s.steps; ++k) {
    for (std::size_t i = 0; i < kCorners; ++i) {
      const Command& c = r.steps[static_cast<std::size_t>(k - 1)][i];
      ASSERT_EQ(c.enable, 0.0) << "corner " << i << " step " << k;
      ASSERT_EQ(c.current_ma, 0.0) << "corner " << i << " step " << k;
    }
  }
  EXPECT_GE(Trips(r.stats[2], FaultCause::kStaleSensor), 1U);
  EXPECT_EQ(Trips(r.stats[2], FaultCause::kOtherChannel), 0U);
  for (const std::size_t i : {0U, 1U, 3U}) {
    EXPECT_EQ(Trips(r.stats[i], FaultCause::kOtherChannel), 1U) << "corner " << i;
    EXPECT_EQ(Trips(r.stats[i], FaultCause::kStaleSensor), 0U) << "corner " << i;
  }
  EXPECT_EQ(r.loop_allocations, 0U);
}

TEST(CanChannelsLockstep, OneCornerFaultsPolicyChannelLeavesTheOthersCommanding) {
  Scenario s;
  s.policy = FaultPolicy::kChannel;
  s.silent_corner = 2;
  s.silent_from = 200;
  const Result r = RunVehicle(s);
  ASSERT_EQ(r.error, "");
  for (int k = 200; k <= s.steps; ++k) {
    const Step& st = r.steps[static_cast<std::size_t>(k - 1)];
    for (const std::size_t i : {0U, 1U, 3U}) {
      ASSERT_EQ(st[i].enable, 1.0) << "corner " << i << " step " << k;
    }
  }
  EXPECT_EQ(r.steps.back()[2].enable, 0.0);
  EXPECT_GE(Trips(r.stats[2], FaultCause::kStaleSensor), 1U);
  for (const std::size_t i : {0U, 1U, 3U}) {
    EXPECT_EQ(Trips(r.stats[i], FaultCause::kOtherChannel), 0U) << "corner " << i;
  }
}

}  // namespace
}  // namespace mrd::firmware
