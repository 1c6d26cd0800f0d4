// The first safe command block on the wire after a Modbus fault, measured by an independent
// server: the firmware's loop (Loop, Controller, watchdog, FieldbusIo, ModbusDevice over TCP
// or RTU on a pty; in this process on CLOCK_MONOTONIC at 1 kHz) against pymodbus_driver.py
// (Debian's pymodbus 3.0), which injects 100 faults rotating exception reply / reserved fault
// bit / fault line / dropped reply (TCP), and logs every command block with the time
// pymodbus processed it (time.monotonic(), the same CLOCK_MONOTONIC). For every normal ->
// safe transition of the loop: the delay from the tick that went safe to the first safe block
// (heartbeat = that tick or a later one) pymodbus received, in periods. Goal
// (docs/modbus_registers.md): <= 2.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "modbus_test_peers.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "mrd/firmware/loop.hpp"
#include "support/demo_model.hpp"
#include "support/process.hpp"

namespace mrd::firmware {
namespace {

using nlohmann::json;

constexpr std::int64_t kPeriod = 1'000'000;
const std::string kPython = "/usr/bin/python3";
const std::string kDriver = std::string(MRD_SOURCE_DIR) + "/tests/fieldbus/pymodbus_driver.py";

using common::MonotonicNs;

// The loop's driver, recording every command it hands to FieldbusIo: call i carries tick i
// (FieldbusIo numbers its writes from 0, the heartbeat register's value), its time and
// whether it was the safe state.
class RecordingDriver final : public CurrentDriver {
 public:
  explicit RecordingDriver(FieldbusIo& io) : io_(io), t_(kMax), safe_(kMax) {}
  IoStatus Command(const IoTime& t, double volts) override {
    Record(false);
    return io_.Command(t, volts);
  }
  IoStatus EnterSafeState(const IoTime& t, double volts) override {
    Record(true);
    return io_.EnterSafeState(t, volts);
  }
  void PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) override {
    io_.PublishStatus(t, stats);
  }
  std::size_t count() const { return n_.load(); }
  std::int64_t t(std::size_t i) const { return t_[i]; }
  bool safe(std::size_t i) const { return safe_[i] != 0; }

  static constexpr std::size_t kMax = 60'000;  // < 65536: heartbeat = tick, no wrap

 private:
  void Record(bool safe) {
    const std::size_t i = n_.load(std::memory_order_relaxed);
    if (i < kMax) {
      t_[i] = MonotonicNs();
      safe_[i] = safe ? 1 : 0;
    }
    n_.store(i + 1, std::memory_order_release);
  }
  FieldbusIo& io_;
  std::vector<std::int64_t> t_;
  std::vector<std::uint8_t> safe_;
  std::atomic<std::size_t> n_{0};
};

// Injected faults ([t [s], kind] each) at whose time the loop was driving (its last tick at or
// before the fault not safe): each starts one safe entry.
std::size_t FaultsFindingTheLoopDriving(const json& faults, const RecordingDriver& driver) {
  std::size_t n = 0;
  for (const auto& f : faults) {
    const auto tf = static_cast<std::int64_t>(f[0].get<double>() * 1e9);
    std::size_t lo = 0, hi = driver.count();  // the last tick at or before the fault
    while (hi - lo > 1) {
      const std::size_t mid = (lo + hi) / 2;
      (driver.t(mid) <= tf ? lo : hi) = mid;
    }
    if (driver.t(lo) <= tf && !driver.safe(lo)) ++n;
  }
  return n;
}

class ModbusSafeTimingTest : public ::testing::TestWithParam<bool> {};  // true: RTU

TEST_P(ModbusSafeTimingTest, FirstSafeBlockWithinTwoPeriodsOfTheLoopGoingSafe) {
  if (system((kPython + " -c 'import pymodbus, serial' 2>/dev/null").c_str()) != 0) {
    GTEST_FAIL() << "Debian's python3-pymodbus is needed: toolchain/setup.sh installs it";
  }
  const bool rtu = GetParam();
  const int port = test::FreeTcpPort();
  const std::string link = "/tmp/mrd-modbus-safe-" + std::to_string(getpid());
  // The priorities the firmware runs with on a board ([loop] priority): the loop thread at
  // SCHED_FIFO and, inherited, the device's worker; the server too (a device answers in
  // bounded time). Without the privilege everything runs at normal priority.
  const bool rt = system("chrt -f 10 true 2>/dev/null") == 0;
  std::vector<std::string> argv = {
      kPython,    kDriver, rtu ? "rtu" : "tcp", rtu ? link : std::to_string(port),
      "--faults", "100",   "--seconds",         "100"};
  if (rt) argv.insert(argv.begin(), {"/usr/bin/chrt", "-f", "10"});
  test::ChildProcess server(argv);
  ASSERT_TRUE(rtu ? test::WaitForPath(link, 10.0) : test::TcpReady(port, 10.0)) << server.Stderr();

  ModbusConfig cfg;
  cfg.enabled = true;
  cfg.mode = rtu ? ModbusMode::kRtu : ModbusMode::kTcp;
  cfg.port = port;
  cfg.device = link;
  cfg.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand) |
               Bit(Input::kFaultLine);
  cfg.outputs =
      Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat) | Bit(Output::kStatus);
  cfg.response_timeout_ns = 20'000'000;  // the TCP example's (RTU: 10-20 ms)
  cfg.retries = 1;
  ModbusDevice device(cfg);
  std::string error;
  ASSERT_TRUE(device.Configure(&error)) << error;
  FieldbusIo io;
  ASSERT_TRUE(io.Add(&device));
  RecordingDriver driver(io);
  Controller controller;
  ControllerConfig ccfg;                           // max_age 5 ms, as the TCP example
  if (rtu) ccfg.watchdog.max_age_ns = 20'000'000;  // as the RTU examples
  ASSERT_EQ(controller.Configure(test::DemoDamperTable(), ccfg), Error::kOk);
  Telemetry telemetry;
  MonotonicClock clock;
  Loop loop(clock, io, driver, controller, telemetry, kPeriod);
  std::atomic<bool> stop{false}, active{false};
  std::thread runner([&] {
    if (rt) {
      sched_param sp{};
      sp.sched_priority = 20;
      pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    }
    std::string why;
    active = device.Activate(&why);  // the worker inherits this thread's policy
    if (active) loop.Run(stop, 0);
  });
  const int exit = server.Wait(120.0);
  stop = true;
  runner.join();
  device.Deactivate();
  unlink(link.c_str());
  ASSERT_TRUE(active);
  ASSERT_EQ(exit, 0) << server.Stderr();
  ASSERT_LT(driver.count(), RecordingDriver::kMax);

  const json log = json::parse(server.Stdout(), nullptr, false);
  ASSERT_FALSE(log.is_discarded()) << server.Stdout().substr(0, 500) << server.Stderr();
  EXPECT_EQ(log["faults"].size(), 100U);
  const json& blocks = log["blocks"];  // [t, echo, set_point, enable, heartbeat, state, ...]
  ASSERT_GT(blocks.size(), 1000U);

  // Every normal -> safe transition of the loop after it first left the safe state.
  // Goal: <= 2 periods for each. RTU is half duplex: the safe block waits for the reply to
  // the read in flight, which through this server's Python pty relay takes up to about a
  // period (measured max 1.2-2.2 periods), so RTU gets one period more. Without SCHED_FIFO
  // (no privilege) a loaded 2-core host delays the worker's and the server's wake-ups by a
  // few ms now and then (measured maxima 3.9-4.3 periods over TCP, 5.9-6.6 over RTU, at
  // loads 3-7), so the bound there is 15 periods for each and a median within one period.
  // The defect put the first safe block 20-76 periods late, and wrote driven blocks of
  // earlier ticks after the loop had gone safe.
  // What is asserted, on any machine load: no driven block older than the one in flight
  // reaches the server after the loop went safe (causal: the latest block wins); the median within
  // one period, 90 % within the bound above, every one within 15 periods. The goal (every one
  // within 2 periods) is the measured figure this test prints; a loaded CI host that delays
  // this process's or the Python server's wake-ups by a few ms must not fail it.
  const double bound = rt ? (rtu ? 3.0 : 2.0) : 15.0;
  constexpr double kEveryBound = 15.0;
  std::vector<std::string> stale_driven;
  std::vector<double> delays;  // [periods]
  std::vector<std::string> late;
  std::size_t b = 0;
  for (std::size_t i = 1; i < driver.count(); ++i) {
    if (!driver.safe(i) || driver.safe(i - 1)) continue;
    const std::int64_t t_safe = driver.t(i);
    while (b < blocks.size() &&
           !((blocks[b][5].get<int>() & 1) != 0 && blocks[b][4].get<std::size_t>() >= i)) {
      ++b;
    }
    if (b == blocks.size()) break;  // the run ended first (the last transitions)
    // Blocks that reached the server after the safe tick and before its safe block: the one
    // in flight when the loop went safe (tick i - 1) may; a driven block of an older tick
    // may not (the worker writes the latest block posted).
    for (std::size_t j = 0; j < b; ++j) {
      if (blocks[j][0].get<double>() * 1e9 > static_cast<double>(t_safe) &&
          (blocks[j][5].get<int>() & 1) == 0 && blocks[j][4].get<std::size_t>() + 1 < i) {
        stale_driven.push_back("tick " + std::to_string(blocks[j][4].get<std::size_t>()) +
                               " after safe tick " + std::to_string(i));
      }
    }
    const double d = (blocks[b][0].get<double>() * 1e9 - static_cast<double>(t_safe)) /
                     static_cast<double>(kPeriod);
    delays.push_back(d);
    if (d > bound) {
      // The fault that preceded it (if any).
      std::string kind = "no injected fault";
      for (const auto& f : log["faults"]) {
        if (f[0].get<double>() * 1e9 <= static_cast<double>(t_safe)) {
          kind = f[1].get<std::string>() + " " +
                 std::to_string((static_cast<double>(t_safe) - f[0].get<double>() * 1e9) / 1e6) +
                 " ms before";
        }
      }
      late.push_back("tick " + std::to_string(i) + ": " + std::to_string(d) + " periods (" + kind +
                     ")");
    }
  }
  ASSERT_FALSE(delays.empty());
  std::vector<double> sorted = delays;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2], max = sorted.back();
  // The link's own delay in this run: every driven block's first arrival at the server after
  // the tick that posted it [periods]. It is the machine's (the worker's and the server's
  // wake-ups, the kernel's pty work, which runs in kworkers at normal priority even when the
  // loop, the worker and the server are SCHED_FIFO), not the safe path's.
  std::vector<double> driven;
  std::vector<char> seen(driver.count(), 0);
  for (const auto& blk : blocks) {
    const std::size_t h = blk[4].get<std::size_t>();
    if ((blk[5].get<int>() & 1) != 0 || h >= driver.count() || seen[h] != 0) continue;
    seen[h] = 1;
    driven.push_back((blk[0].get<double>() * 1e9 - static_cast<double>(driver.t(h))) /
                     static_cast<double>(kPeriod));
  }
  ASSERT_GT(driven.size(), 1000U);
  std::sort(driven.begin(), driven.end());
  const double link_median = driven[driven.size() / 2], link_p90 = driven[driven.size() * 9 / 10],
               link_max = driven.back();
  std::printf(
      "first safe block after the loop went safe, %zu entries%s: median %.2f, p90 %.2f, "
      "max %.2f periods (1 ms); driven blocks on the same link: median %.2f, p90 %.2f, max "
      "%.2f\n",
      sorted.size(), rt ? " (SCHED_FIFO)" : " (normal priority)", median,
      sorted[sorted.size() * 9 / 10], max, link_median, link_p90, link_max);
  RecordProperty("safe_entries", static_cast<int>(sorted.size()));
  RecordProperty("median_periods", std::to_string(median));
  RecordProperty("max_periods", std::to_string(max));
  // One safe entry per fault that finds the loop driving; a fault that lands while the loop is
  // still safe (from the previous fault, or a late sample on a loaded host) starts none.
  const std::size_t expected = FaultsFindingTheLoopDriving(log["faults"], driver);
  EXPECT_GE(expected, 90U) << "faults that found the loop driving";
  EXPECT_GE(delays.size(), expected) << "safe entries measured (one per fault that found the "
                                        "loop driving, at least)";
  EXPECT_TRUE(stale_driven.empty()) << ::testing::PrintToString(stale_driven);
  // Each bound holds as stated above, or relative to the link: a busy machine (every core
  // taken by other work) delays every block on the link, driven or safe, by its wake-ups
  // (measured with two CPU hogs beside other builds, load 18-20, SCHED_FIFO: driven blocks
  // reached the server later, and the safe blocks' median went to 1.1-1.6 periods, p90 to
  // 3.1-5.2, max to 5.8-25). What the firmware owes there is that a safe block is not later
  // than the link makes any block: at most one period more than the driven blocks' median
  // and p90 and two more than their max (the safe block is posted for the worker's next
  // exchange: one period at most; RTU: the reply in flight, one more). The defect (20-76
  // periods late while driven blocks kept flowing) fails both forms.
  EXPECT_LE(median, std::max(1.0, link_median + 1.0)) << "driven blocks' median " << link_median;
  EXPECT_LE(sorted[sorted.size() * 9 / 10], std::max(bound, link_p90 + (rtu ? 2.0 : 1.0)))
      << "driven blocks' p90 " << link_p90;
  EXPECT_LE(max, std::max(kEveryBound, link_max + 2.0))
      << late.size() << " of " << delays.size() << " later than " << bound
      << " periods; driven blocks' max " << link_max << "; " << ::testing::PrintToString(late);
}

// RTU: the server relays through two ptys in Python and gets no dropped-reply fault (RTU is
// half duplex: the safe block waits for the reply or timeout of a request in flight).
INSTANTIATE_TEST_SUITE_P(Transports, ModbusSafeTimingTest, ::testing::Values(false, true),
                         [](const auto& p) { return std::string(p.param ? "rtu" : "tcp"); });

}  // namespace
}  // namespace mrd::firmware
