// Loop periods on the Modbus device allocate nothing: the loop (controller, watchdog,
// FieldbusIo) ticks on CLOCK_MONOTONIC against the device while its worker exchanges the
// register blocks with a libmodbus server (mrd-hil's port) over TCP and over a pty. After a
// warm-up that connects and exchanges the first blocks, the allocations are counted per thread:
// none on the loop's thread (this test's, but for the calls that drive the simulated server's
// side) and none on the device's worker; the server's own thread is the harness, not the
// firmware, and is not asserted on. A failure names the thread and its call stack. Built a
// second time with MRD_MODBUS_PROFILE (modbus_profile_no_alloc_tests): the device and the
// harness's server then run a device profile's map (grouped reads at two unit ids, typed
// float32 values, coil and register writes, the set-point through the CommandMap), and with
// four channel views of one link (ModbusChannels on the four-corner maps, one Loop of four
// channels against one server serving the four maps).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>
#include <thread>
#include <vector>

#include "modbus_test_peers.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/io/modbus/modbus_channels.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "support/alloc_counter.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;

// Warm-up, then 1000 guarded loop periods; rtu: over a pty, else TCP on loopback. profile:
// a Modbus device profile file for both sides (nullptr: the built-in map).
void LoopPeriodsAllocateNothing(bool rtu, const char* profile = nullptr) {
  const int tcp_port = test::FreeTcpPort();
  const std::string link = "/tmp/mrd-modbus-alloc-" + std::to_string(getpid());
  std::shared_ptr<profile::ModbusProfile> mp;
  std::string error;
  if (profile != nullptr) {
    mp = std::make_shared<profile::ModbusProfile>();
    ASSERT_TRUE(profile::LoadModbusProfile(profile, mp.get(), &error)) << error;
  }
  const std::string tcp = "127.0.0.1:" + std::to_string(tcp_port);
  auto port = mp != nullptr ? hil::MakeModbusProfilePort(rtu, rtu ? link : tcp, mp)
              : rtu         ? hil::MakeModbusRtuPort(link)
                            : hil::MakeModbusTcpPort(tcp);
  ASSERT_TRUE(port->Open(&error)) << error;

  ModbusConfig cfg;
  cfg.enabled = true;
  cfg.mode = rtu ? ModbusMode::kRtu : ModbusMode::kTcp;
  cfg.port = tcp_port;
  cfg.device = link;
  cfg.modbus_profile = mp;
  cfg.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand);
  cfg.outputs =
      Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat) | Bit(Output::kStatus);
  const std::set<pid_t> before_device = test::ProcessThreads();
  ModbusDevice device(cfg);
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  std::set<pid_t> device_threads;  // the device's worker
  for (const pid_t t : test::ProcessThreads()) {
    if (before_device.count(t) == 0) device_threads.insert(t);
  }
  ASSERT_EQ(device_threads.size(), 1U) << "the device's worker thread not found";
  const pid_t loop_thread = gettid();
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&device));
  Controller controller;
  ControllerConfig ccfg;
  ccfg.watchdog.max_age_ns = 20'000'000;  // tolerant of a loaded machine
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), ccfg), Error::kOk);
  Telemetry telemetry;
  MonotonicClock clock;
  Loop loop(clock, io, io, controller, telemetry, kPeriod);

  std::uint32_t seq = 0;
  hil::DriverInput in;
  const auto period = [&] {
    const double t = static_cast<double>(++seq) * 1e-3;
    hil::SensorOutput out;
    out.seq = seq;
    out.sample.x = std::sin(2.0 * M_PI * 2.0 * t);
    out.sample.v = 4.0 * M_PI * std::cos(2.0 * M_PI * 2.0 * t);
    out.sample.demand = 500.0 * std::tanh(out.sample.v / 2.0);
    {
      test::NotCounted server_side;  // the simulated driver's side, driven from this thread
      port->Publish(out);
      port->Poll(&in);
    }
    loop.Tick(clock.Now());
    clock.SleepUntil(clock.Now() + kPeriod);
  };
  for (int k = 0; k < 500 || device.counters().tx_ok < 50; ++k) {  // warm-up
    period();
    ASSERT_LT(k, 10'000) << "no exchange";
  }
  const DeviceCounters before = device.counters();
  const std::uint64_t safe_before = loop.stats().watchdog.safe_periods;
  int periods = 0;
  const auto driven = [&] {  // guarded periods out of the safe state
    return static_cast<std::uint64_t>(periods) - (loop.stats().watchdog.safe_periods - safe_before);
  };
  test::ThreadAllocationGuard guard;
  {
    // At least 1000 periods, and on until the bus carried 200 samples and 200 commands and
    // the loop drove (out of the safe state) for 500 of them: a loaded machine or a sanitizer
    // build delays samples past the watchdog's age limit, so it needs more periods to cover
    // the driving path as often (bounded).
    const auto carried = [&] {
      const DeviceCounters c = device.counters();
      return c.rx_ok - before.rx_ok > 200U && c.tx_ok - before.tx_ok > 200U;
    };
    while (periods < 1000 || ((!carried() || driven() < 500U) && periods < 20'000)) {
      period();
      ++periods;
    }
    guard.Stop();
  }
  device.Deactivate();
  port->Close();
  EXPECT_EQ(guard.CountOn(loop_thread), 0U)
      << "the loop's thread " << loop_thread << " allocated:\n"
      << guard.Report();
  for (const pid_t t : device_threads) {
    EXPECT_EQ(guard.CountOn(t), 0U) << "the device's worker " << t << " allocated:\n"
                                    << guard.Report();
  }
  if (guard.Total() != 0)
    std::printf("allocations elsewhere (harness):\n%s", guard.Report().c_str());
  const DeviceCounters after = device.counters();
  // Reconnects while counted (a timeout under load breaks the link: the worker reconnects).
  std::printf("guarded periods: %d, reconnects: %llu\n", periods,
              static_cast<unsigned long long>(after.reconnects - before.reconnects));
  testing::Test::RecordProperty("reconnects",
                                static_cast<int>(after.reconnects - before.reconnects));
  EXPECT_GT(after.rx_ok - before.rx_ok, 200U);  // the bus really carried samples
  EXPECT_GT(after.tx_ok - before.tx_ok, 200U);  // and commands
  // The guarded periods covered the driving path (commands out of the safe state) 500 times.
  EXPECT_GE(driven(), 500U) << "of " << periods << " guarded periods";
}

#ifdef MRD_MODBUS_PROFILE
// Four channel views of one link (the four-corner maps): warm-up, then 1000 guarded periods of
// a four-channel loop; the loop's thread and the one worker allocate nothing.
void FourChannelViewsAllocateNothing(bool rtu) {
  constexpr std::size_t kN = 4;
  const int tcp_port = test::FreeTcpPort();
  const std::string link = "/tmp/mrd-modbus-alloc4-" + std::to_string(getpid());
  std::vector<std::shared_ptr<const profile::ModbusProfile>> maps;
  std::string error;
  for (const char* c : {"fl", "fr", "rl", "rr"}) {
    auto mp = std::make_shared<profile::ModbusProfile>();
    ASSERT_TRUE(profile::LoadModbusProfile(
        std::string(MRD_SOURCE_DIR "/firmware/profiles/modbus-corner-") + c + ".toml", mp.get(),
        &error))
        << error;
    maps.push_back(mp);
  }
  auto ports = hil::MakeModbusProfilePorts(
      rtu, rtu ? link : "127.0.0.1:" + std::to_string(tcp_port), maps, &error);
  ASSERT_EQ(ports.size(), kN) << error;
  for (auto& p : ports) ASSERT_TRUE(p->Open(&error)) << error;

  ModbusConfig cfg;
  cfg.enabled = true;
  cfg.mode = rtu ? ModbusMode::kRtu : ModbusMode::kTcp;
  cfg.port = tcp_port;
  cfg.device = link;
  cfg.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand);
  cfg.outputs =
      Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat) | Bit(Output::kStatus);
  const std::set<pid_t> before_device = test::ProcessThreads();
  ModbusChannels device(cfg, maps);
  ASSERT_TRUE(device.ok(&error)) << error;
  for (std::size_t k = 0; k < kN; ++k) {
    ASSERT_TRUE(device.channel(k).Configure(&error) && device.channel(k).Activate(&error)) << error;
  }
  std::set<pid_t> device_threads;
  for (const pid_t t : test::ProcessThreads()) {
    if (before_device.count(t) == 0) device_threads.insert(t);
  }
  ASSERT_EQ(device_threads.size(), 1U) << "one worker for the four channels";
  const pid_t loop_thread = gettid();
  std::array<FieldbusIo, kN> io;
  std::array<Controller, kN> controllers;
  std::array<Telemetry, kN> telemetry;
  std::vector<std::unique_ptr<Channel>> channels;
  std::vector<Channel*> list;
  ControllerConfig ccfg;
  ccfg.watchdog.max_age_ns = 20'000'000;  // tolerant of a loaded machine
  for (std::size_t k = 0; k < kN; ++k) {
    ASSERT_TRUE(io[k].Add(&device.channel(k)));
    ASSERT_EQ(controllers[k].Configure(test::DemoDamperTable(), ccfg), Error::kOk);
    channels.push_back(std::make_unique<Channel>(io[k], io[k], controllers[k], telemetry[k]));
    list.push_back(channels.back().get());
  }
  MonotonicClock clock;
  Loop loop(clock, list.data(), list.size(), FaultPolicy::kChannel, kPeriod);
  ASSERT_TRUE(loop.ok());

  std::uint32_t seq = 0;
  const auto period = [&] {
    const double t = static_cast<double>(++seq) * 1e-3;
    {
      test::NotCounted server_side;  // the simulated plant's side, driven from this thread
      for (std::size_t k = 0; k < kN; ++k) {
        hil::SensorOutput out;
        out.seq = seq;
        const double a = 1.0 + 0.2 * static_cast<double>(k);
        out.sample.x = a * std::sin(2.0 * M_PI * 2.0 * t);
        out.sample.v = a * 4.0 * M_PI * std::cos(2.0 * M_PI * 2.0 * t);
        out.sample.demand = 500.0 * std::tanh(out.sample.v / 2.0);
        ports[k]->Publish(out);
        hil::DriverInput in;
        ports[k]->Poll(&in);
      }
    }
    loop.Tick(clock.Now());
    clock.SleepUntil(clock.Now() + kPeriod);
  };
  const auto tx_min = [&] {
    std::uint64_t m = ~0ULL;
    for (std::size_t k = 0; k < kN; ++k) m = std::min(m, device.channel(k).counters().tx_ok);
    return m;
  };
  for (int k = 0; k < 500 || tx_min() < 50; ++k) {  // warm-up
    period();
    ASSERT_LT(k, 10'000) << "no exchange";
  }
  std::array<DeviceCounters, kN> before;
  for (std::size_t k = 0; k < kN; ++k) before[k] = device.channel(k).counters();
  std::array<std::uint64_t, kN> safe_before;
  for (std::size_t k = 0; k < kN; ++k) {
    safe_before[k] = loop.channel(k).stats().watchdog.safe_periods;
  }
  test::ThreadAllocationGuard guard;
  int periods = 0;
  const auto driven = [&] {  // guarded periods out of the safe state, the fewest of a channel
    std::uint64_t m = ~0ULL;
    for (std::size_t k = 0; k < kN; ++k) {
      const std::uint64_t safe = loop.channel(k).stats().watchdog.safe_periods - safe_before[k];
      m = std::min(m, static_cast<std::uint64_t>(periods) - safe);
    }
    return m;
  };
  const auto carried = [&] {
    for (std::size_t k = 0; k < kN; ++k) {
      const DeviceCounters c = device.channel(k).counters();
      if (c.rx_ok - before[k].rx_ok <= 100U || c.tx_ok - before[k].tx_ok <= 100U) return false;
    }
    return true;
  };
  while (periods < 1000 || ((!carried() || driven() < 500U) && periods < 20'000)) {
    period();
    ++periods;
  }
  guard.Stop();
  for (std::size_t k = 0; k < kN; ++k) device.channel(k).Deactivate();
  for (auto& p : ports) p->Close();
  EXPECT_EQ(guard.CountOn(loop_thread), 0U)
      << "the loop's thread " << loop_thread << " allocated:\n"
      << guard.Report();
  for (const pid_t t : device_threads) {
    EXPECT_EQ(guard.CountOn(t), 0U) << "the link's worker " << t << " allocated:\n"
                                    << guard.Report();
  }
  EXPECT_TRUE(carried()) << "each channel's samples and commands went over the link";
  EXPECT_GE(driven(), 500U) << "of " << periods << " guarded periods";
  std::printf("guarded periods (four channels): %d\n", periods);
}
#endif

// Plain tests (not parameterised: gtest's parameter registry trips GCC's new/delete check
// against the counting operators).
#ifdef MRD_MODBUS_PROFILE
TEST(ModbusProfileNoAllocTest, LoopPeriodsOverTcpAllocateNothing) {
  LoopPeriodsAllocateNothing(false, MRD_MODBUS_PROFILE);
}
TEST(ModbusProfileNoAllocTest, LoopPeriodsOverRtuAllocateNothing) {
  LoopPeriodsAllocateNothing(true, MRD_MODBUS_PROFILE);
}
// The worker's periodic writes (a keep-alive every 5 ms) allocate nothing either.
TEST(ModbusProfileNoAllocTest, PeriodicWritesAllocateNothing) {
  LoopPeriodsAllocateNothing(false, MRD_MODBUS_WATCHDOG_PROFILE);
}
TEST(ModbusProfileNoAllocTest, FourChannelViewsOverTcpAllocateNothing) {
  FourChannelViewsAllocateNothing(false);
}
TEST(ModbusProfileNoAllocTest, FourChannelViewsOverRtuAllocateNothing) {
  FourChannelViewsAllocateNothing(true);
}
#else
TEST(ModbusNoAllocTest, LoopPeriodsOverTcpAllocateNothing) { LoopPeriodsAllocateNothing(false); }
TEST(ModbusNoAllocTest, LoopPeriodsOverRtuAllocateNothing) { LoopPeriodsAllocateNothing(true); }
#endif

}  // namespace
}  // namespace mrd::firmware
