// Four damper channels closed in lockstep over one Modbus link: the shipped four-corner maps
// (firmware/profiles/modbus-corner-*.toml) served by the harness's ports on one server
// (MakeModbusProfilePorts), the firmware's ModbusChannels with a channel view per corner, four
// FieldbusIo and Channels on one Loop under the grant clock. Each corner's sensor values are
// its own and follow its previous command (a closed loop); each corner's command must follow
// its own sample (its echo is its own step's seq), the link must read all four corners in the
// plan's two requests, and the commands of every step must be bit-identical on repeat and with
// the firmware stopped 150 ms mid-run. A NaN in one corner's sensor block faults that channel's
// read alone, a fault its driver reports that channel alone (FaultPolicy::kChannel: the other
// three keep driving). Over Modbus TCP and RTU (a pseudo-terminal). Nothing is asserted on time.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "modbus_lockstep_setup.hpp"
#include "modbus_test_peers.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/io/modbus/modbus_channels.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/modbus_channels.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kMs = 1'000'000;  // [ns]
constexpr std::int64_t kPeriod = kMs;
constexpr std::size_t kCorners = 4;
constexpr int kSteps = 40;
constexpr const char* kNames[kCorners] = {"fl", "fr", "rl", "rr"};

std::vector<std::shared_ptr<const profile::ModbusProfile>> CornerMaps() {
  std::vector<std::shared_ptr<const profile::ModbusProfile>> maps;
  for (const char* c : kNames) {
    auto p = std::make_shared<profile::ModbusProfile>();
    std::string error;
    EXPECT_TRUE(profile::LoadModbusProfile(
        std::string(MRD_SOURCE_DIR "/firmware/profiles/modbus-corner-") + c + ".toml", p.get(),
        &error))
        << error;
    maps.push_back(p);
  }
  return maps;
}

// What the harness saw of one corner's command of one step.
struct Seen {
  double volts = 0.0;
  std::uint32_t echo = 0;
  bool safe = false;
  bool operator==(const Seen& o) const {
    return std::memcmp(&volts, &o.volts, sizeof volts) == 0 && echo == o.echo && safe == o.safe;
  }
};

struct Options {
  bool rtu = false;
  int pause_at = -1;    // the loop's thread stops 150 ms after this step
  int nan_corner = -1;  // this corner's velocity register holds a NaN at step nan_step
  int nan_step = -1;
  int fault_corner = -1;  // this corner's driver reports a fault at step fault_step
  int fault_step = -1;
};

// The firmware stopped (as a SIGSTOP would) after one period.
class Pause final : public PeriodObserver {
 public:
  explicit Pause(std::uint64_t at) : at_(at) {}
  void OnPeriod(const PeriodRecord& r) override {
    if (r.period == at_) std::this_thread::sleep_for(std::chrono::milliseconds(150));
  }

 private:
  std::uint64_t at_;
};

struct RunResult {
  std::vector<std::array<Seen, kCorners>> steps;  // [step][corner]
  std::array<DeviceCounters, kCorners> counters{};
  std::array<std::uint64_t, kCorners> received{};
  std::size_t reads = 0;
};

// One corner's sensor step: its own excitation (phase and amplitude per corner) minus a share
// of its previous command (the plant closes the loop).
hil::SensorOutput Step(std::size_t k, int n, double last_volts) {
  const double t = static_cast<double>(n) * 1e-3;
  const double a = 1.0 + 0.4 * static_cast<double>(k);
  hil::SensorOutput o;
  o.seq = static_cast<std::uint32_t>(n * 10 + static_cast<int>(k));  // per corner: routing
  o.sample.x = 0.2 * a * std::sin(40.0 * t + static_cast<double>(k));
  o.sample.v = 6.0 * a * std::cos(40.0 * t + static_cast<double>(k)) - 0.5 * last_volts;
  o.sample.demand = 90.0 * o.sample.v;
  return o;
}

void RunFourCorners(const Options& opt, RunResult* out) {
  const auto maps = CornerMaps();
  std::string error;
  const int tcp = test::FreeTcpPort();
  const std::string link = "/tmp/mrd-modbus-corners-" + std::to_string(getpid());
  auto ports = hil::MakeModbusProfilePorts(
      opt.rtu, opt.rtu ? link : "127.0.0.1:" + std::to_string(tcp), maps, &error);
  ASSERT_EQ(ports.size(), kCorners) << error;
  for (auto& p : ports) {
    p->SetLockstep(true);
    ASSERT_TRUE(p->Open(&error)) << error;
  }
  ModbusConfig cfg = LockstepTcp(tcp, 2000 * kMs);
  if (opt.rtu) {
    cfg.mode = ModbusMode::kRtu;
    cfg.device = link;
  }
  cfg.period_ns = kPeriod;
  ModbusChannels device(cfg, maps);
  ASSERT_TRUE(device.ok(&error)) << error;
  out->reads = device.plan().reads.size();

  std::array<FieldbusIo, kCorners> io;
  std::array<Controller, kCorners> controllers;
  std::array<Telemetry, kCorners> telemetry;
  std::vector<std::unique_ptr<Channel>> channels;
  std::vector<Channel*> list;
  for (std::size_t k = 0; k < kCorners; ++k) {
    ASSERT_TRUE(io[k].Add(&device.channel(k)));
    ASSERT_EQ(controllers[k].Configure(test::DemoDamperTable(), ControllerConfig{}), Error::kOk);
    channels.push_back(std::make_unique<Channel>(io[k], io[k], controllers[k], telemetry[k]));
    list.push_back(channels.back().get());
  }
  for (std::size_t k = 0; k < kCorners; ++k) {
    ASSERT_TRUE(device.channel(k).Configure(&error)) << error;
    ASSERT_TRUE(device.channel(k).Activate(&error)) << error;
  }
  ASSERT_NE(device.channel(0).grant_source(), nullptr);
  EXPECT_EQ(device.channel(1).grant_source(), nullptr) << "one grant source per link";
  std::atomic<bool> stop{false};
  GrantClock clock(*device.channel(0).grant_source(), 10'000 * kMs, &stop);
  Loop loop(clock, list.data(), list.size(), FaultPolicy::kChannel, kPeriod);
  ASSERT_TRUE(loop.ok());
  Pause pause(opt.pause_at >= 0 ? static_cast<std::uint64_t>(opt.pause_at) : ~0ULL);
  if (opt.pause_at >= 0) channels[0]->SetObserver(&pause);
  std::thread firmware([&] { loop.Run(stop, 0); });

  std::array<double, kCorners> last{};
  for (int n = 1; n <= kSteps; ++n) {
    for (std::size_t k = 0; k < kCorners; ++k) {
      hil::SensorOutput o = Step(k, n, last[k]);
      if (static_cast<int>(k) == opt.nan_corner && n == opt.nan_step) {
        o.fault = hil::SensorFault::kNan;
      }
      o.driver_fault = static_cast<int>(k) == opt.fault_corner && n == opt.fault_step;
      ports[k]->Publish(o);
    }
    ASSERT_TRUE(ports[0]->SendGrant(n * kPeriod));
    std::array<Seen, kCorners> seen{};
    for (std::size_t k = 0; k < kCorners; ++k) {
      hil::DriverInput in;
      ASSERT_TRUE(test::WaitFor(
          [&] {
            ports[k]->Wait(10 * kMs);
            ports[k]->Poll(&in);
            return in.has_command;
          },
          5.0))
          << "no command of corner " << kNames[k] << " at step " << n;
      seen[k] = {in.volts, in.echo, in.safe};
      last[k] = in.volts;
    }
    out->steps.push_back(seen);
  }
  stop.store(true);
  firmware.join();
  for (std::size_t k = 0; k < kCorners; ++k) device.channel(k).Deactivate();
  for (std::size_t k = 0; k < kCorners; ++k) {
    out->counters[k] = device.channel(k).counters();
    out->received[k] = ports[k]->counters().received;
  }
  for (auto& p : ports) p->Close();
}

void ExpectClosedAndRouted(const RunResult& r) {
  ASSERT_EQ(r.steps.size(), static_cast<std::size_t>(kSteps));
  // The four corners' sensor blocks and the grant in one request, the four fault words in one.
  EXPECT_EQ(r.reads, 2U);
  for (int n = 0; n < kSteps; ++n) {
    for (std::size_t k = 0; k < kCorners; ++k) {
      const Seen& s = r.steps[static_cast<std::size_t>(n)][k];
      // Corner k's command of step n+1 was computed from corner k's sample of that step.
      EXPECT_EQ(s.echo, static_cast<std::uint32_t>((n + 1) * 10 + static_cast<int>(k)))
          << "corner " << kNames[k] << " step " << n + 1;
      EXPECT_FALSE(s.safe) << "corner " << kNames[k] << " step " << n + 1;
      EXPECT_TRUE(std::isfinite(s.volts));
    }
  }
  // Each corner's commands are its own: no two corners' command sequences agree, and every
  // corner's command changes over the run.
  for (std::size_t a = 0; a < kCorners; ++a) {
    for (std::size_t b = a + 1; b < kCorners; ++b) {
      int differ = 0;
      for (const auto& st : r.steps) differ += st[a].volts != st[b].volts ? 1 : 0;
      EXPECT_GT(differ, kSteps / 4) << kNames[a] << " and " << kNames[b] << " commanded alike";
    }
    int varied = 0;
    for (std::size_t n = 1; n < r.steps.size(); ++n) {
      varied += r.steps[n][a].volts != r.steps[n - 1][a].volts ? 1 : 0;
    }
    EXPECT_GT(varied, kSteps / 4) << kNames[a] << "'s command hardly changed";
  }
  for (std::size_t k = 0; k < kCorners; ++k) {
    EXPECT_EQ(r.counters[k].rx_ok, static_cast<std::uint64_t>(kSteps)) << kNames[k];
    // Every step's block, and the shutdown's safe block written once by Deactivate.
    EXPECT_EQ(r.received[k], static_cast<std::uint64_t>(kSteps) + 1) << kNames[k];
  }
}

void ExpectSame(const RunResult& a, const RunResult& b) {
  ASSERT_EQ(a.steps.size(), b.steps.size());
  for (std::size_t n = 0; n < a.steps.size(); ++n) {
    for (std::size_t k = 0; k < kCorners; ++k) {
      EXPECT_TRUE(a.steps[n][k] == b.steps[n][k])
          << "corner " << kNames[k] << " step " << n + 1 << ": " << a.steps[n][k].volts << " vs "
          << b.steps[n][k].volts;
    }
  }
  for (std::size_t k = 0; k < kCorners; ++k) {
    EXPECT_EQ(a.counters[k].rx_ok, b.counters[k].rx_ok);
    EXPECT_EQ(a.counters[k].tx_ok, b.counters[k].tx_ok);
    EXPECT_EQ(a.received[k], b.received[k]);
  }
}

void ClosedInLockstepBitIdentical(bool rtu) {
  RunResult first, again, paused;
  Options o;
  o.rtu = rtu;
  RunFourCorners(o, &first);
  if (testing::Test::HasFatalFailure()) return;
  ExpectClosedAndRouted(first);
  RunFourCorners(o, &again);
  if (testing::Test::HasFatalFailure()) return;
  ExpectSame(first, again);
  o.pause_at = kSteps / 2;
  RunFourCorners(o, &paused);
  if (testing::Test::HasFatalFailure()) return;
  ExpectSame(first, paused);
}

TEST(ModbusChannelsLockstep, FourCornersOverTcpClosedAndBitIdentical) {
  ClosedInLockstepBitIdentical(false);
}

TEST(ModbusChannelsLockstep, FourCornersOverRtuClosedAndBitIdentical) {
  ClosedInLockstepBitIdentical(true);
}

// A NaN in the rear-left corner's velocity register: that channel's read alone fails
// (bad_value, counted for it), its command of that step is the safe one, the other three
// corners drive on. Later the front-right corner's driver reports a fault (its own fault word):
// that channel alone goes safe.
TEST(ModbusChannelsLockstep, AFaultInOneCornersRegistersFaultsThatChannelAlone) {
  constexpr int kCorner = 2, kAt = 10, kDriverCorner = 1, kDriverAt = 20;
  Options o;
  o.nan_corner = kCorner;
  o.nan_step = kAt;
  o.fault_corner = kDriverCorner;
  o.fault_step = kDriverAt;
  RunResult r;
  RunFourCorners(o, &r);
  if (testing::Test::HasFatalFailure()) return;
  const auto bad = static_cast<std::size_t>(IoError::kBadValue);
  for (std::size_t k = 0; k < kCorners; ++k) {
    EXPECT_EQ(r.counters[k].errors[bad], k == kCorner ? 1U : 0U) << kNames[k];
    EXPECT_EQ(r.counters[k].rx_ok, static_cast<std::uint64_t>(kSteps) - (k == kCorner ? 1 : 0))
        << kNames[k];
    EXPECT_EQ(r.steps[kAt - 1][k].safe, k == kCorner) << kNames[k] << " at the NaN step";
    EXPECT_FALSE(r.steps[kAt - 2][k].safe) << kNames[k] << " before it";
    EXPECT_EQ(r.steps[kDriverAt - 1][k].safe, k == kDriverCorner)
        << kNames[k] << " at the driver's fault";
    EXPECT_FALSE(r.steps[kDriverAt - 2][k].safe) << kNames[k] << " before it";
  }
}

// Maps that cannot share one link are refused with the file and line.
TEST(ModbusChannelsPlan, MapsWritingOneRegisterOrDifferingInLinkKeysAreRefused) {
  auto maps = CornerMaps();
  std::string error;
  profile::ModbusChannelPlan plan;
  std::vector<const profile::ModbusProfile*> two = {maps[0].get(), maps[0].get()};
  EXPECT_FALSE(profile::PlanModbusChannels(two, &plan, &error));
  EXPECT_NE(error.find("modbus-corner-fl.toml:"), std::string::npos) << error;
  EXPECT_NE(error.find("is written by channel 0"), std::string::npos) << error;
  auto other = std::make_shared<profile::ModbusProfile>(*maps[1]);
  other->max_read = 60;
  std::vector<const profile::ModbusProfile*> differ = {maps[0].get(), other.get()};
  EXPECT_FALSE(profile::PlanModbusChannels(differ, &plan, &error));
  EXPECT_NE(error.find("max_read"), std::string::npos) << error;
  std::vector<const profile::ModbusProfile*> four;
  for (const auto& m : maps) four.push_back(m.get());
  ASSERT_TRUE(profile::PlanModbusChannels(four, &plan, &error)) << error;
  ASSERT_EQ(plan.reads.size(), 2U);
  EXPECT_EQ(plan.reads[0].unit, 1);
  EXPECT_EQ(plan.reads[0].address, 0);
  EXPECT_EQ(plan.reads[0].count, 66);  // four blocks of 16 and the grant at 64
  EXPECT_EQ(plan.served[0], 0xFU);
  EXPECT_EQ(plan.reads[1].unit, 2);
  EXPECT_EQ(plan.reads[1].count, 4);  // the four fault words
  ModbusChannels device(LockstepTcp(1, kMs), {maps[0], maps[0]});
  EXPECT_FALSE(device.ok(&error));
  // Nor does the harness serve them.
  error.clear();
  EXPECT_TRUE(
      hil::MakeModbusProfilePorts(false, "127.0.0.1:1", {maps[0], maps[0]}, &error).empty());
  EXPECT_NE(error.find("is written by channel 0"), std::string::npos) << error;
  // Lockstep needs channel 0's grant.
  auto no_grant = std::make_shared<profile::ModbusProfile>(*maps[0]);
  no_grant->inputs[static_cast<std::size_t>(profile::CanIn::kGrant)].mapped = false;
  ModbusChannels without(LockstepTcp(1, kMs), {no_grant, maps[1]});
  EXPECT_FALSE(without.ok(&error));
  EXPECT_NE(error.find("grant"), std::string::npos) << error;
}

}  // namespace
}  // namespace mrd::firmware
