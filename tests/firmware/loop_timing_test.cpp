// Loop::Run timing figures with a lockstep clock whose periods take a chosen time: overruns,
// skipped deadlines, wake-up latency and execution time against hand-counted values.
#include <gtest/gtest.h>

#include <atomic>
#include <map>

#include "mrd/firmware/loop.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;  // [ns]

// Fresh constant readings; read n (0-based) takes work_ns[n] of clock time (default 0).
class TimedSource final : public SensorSource {
 public:
  explicit TimedSource(LockstepClock& clock) : clock_(clock) {}
  std::map<std::uint64_t, std::int64_t> work_ns;
  IoStatus Read(const IoTime&, SensorFrame* frame) override {
    const std::int64_t now = clock_.Now();
    (*frame)[Input::kVelocity] = {2.0, now};
    (*frame)[Input::kDisplacement] = {0.1, now};
    (*frame)[Input::kDemand] = {100.0, now};
    (*frame)[Input::kBodyVelocity] = {1.0, now};
    const auto it = work_ns.find(reads_++);
    if (it != work_ns.end()) clock_.Advance(it->second);
    return IoStatus::kOk;
  }

 private:
  LockstepClock& clock_;
  std::uint64_t reads_ = 0;
};

// Sleeps overshoot by late_ns[n] on sleep n (a late wake-up).
class LateClock final : public Clock {
 public:
  explicit LateClock(LockstepClock& inner) : inner_(inner) {}
  std::map<std::uint64_t, std::int64_t> late_ns;
  std::int64_t Now() override { return inner_.Now(); }
  void SleepUntil(std::int64_t t_ns) override {
    inner_.SleepUntil(t_ns);
    const auto it = late_ns.find(sleeps_++);
    if (it != late_ns.end()) inner_.Advance(it->second);
  }

 private:
  LockstepClock& inner_;
  std::uint64_t sleeps_ = 0;
};

class NullDriver final : public CurrentDriver {
 public:
  IoStatus Command(const IoTime&, double) override { return IoStatus::kOk; }
  IoStatus EnterSafeState(const IoTime&, double) override { return IoStatus::kOk; }
};

struct TimedRig {
  TimedRig() { EXPECT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk); }
  LockstepClock base;
  LateClock clock{base};
  TimedSource source{base};
  NullDriver driver;
  Controller controller;
  Telemetry telemetry;
  Loop loop{clock, source, driver, controller, telemetry, kPeriod};
  // Runs 20 periods' worth of deadlines (1 ... 20 ms after the start).
  TelemetrySnapshot Run() {
    std::atomic<bool> stop{false};
    loop.Run(stop, 20 * kPeriod);
    return telemetry.Read();
  }
};

TEST(LoopTimingTest, OverrunOfTwoAndAHalfPeriodsSkipsTwoDeadlines) {
  TimedRig rig;
  // Tick 5 wakes at 6 ms and ends at 8.5 ms: the deadlines at 7 and 8 ms are gone, the next
  // wake-up is at 9 ms on time.
  rig.source.work_ns[5] = 2 * kPeriod + kPeriod / 2;
  const TelemetrySnapshot s = rig.Run();
  EXPECT_EQ(s.overruns, 1U);
  EXPECT_EQ(s.missed_periods, 2U);
  EXPECT_EQ(s.ticks, 18U);  // 20 deadlines - 2 skipped
  EXPECT_EQ(s.worst_latency_ns, 0);
  EXPECT_EQ(s.worst_exec_ns, 2 * kPeriod + kPeriod / 2);
  EXPECT_EQ(s.last_exec_ns, 0);
}

TEST(LoopTimingTest, WorkOfExactlyOnePeriodIsNotAnOverrun) {
  TimedRig rig;
  rig.source.work_ns[3] = kPeriod;  // ends exactly at the next deadline
  const TelemetrySnapshot s = rig.Run();
  EXPECT_EQ(s.overruns, 0U);
  EXPECT_EQ(s.missed_periods, 0U);
  EXPECT_EQ(s.ticks, 20U);
  EXPECT_EQ(s.worst_latency_ns, 0);
  EXPECT_EQ(s.worst_exec_ns, kPeriod);
}

TEST(LoopTimingTest, OverrunJustPastTheDeadlineSkipsOneDeadline) {
  TimedRig rig;
  rig.source.work_ns[2] = kPeriod + 1;
  const TelemetrySnapshot s = rig.Run();
  EXPECT_EQ(s.overruns, 1U);
  EXPECT_EQ(s.missed_periods, 1U);
  EXPECT_EQ(s.ticks, 19U);
  EXPECT_EQ(s.worst_latency_ns, 0);
}

TEST(LoopTimingTest, LateWakeUpIsTheWorstLatencyAndCountsNoOverrun) {
  TimedRig rig;
  rig.clock.late_ns[4] = 300'000;  // wakes 0.3 ms late, no work
  rig.clock.late_ns[9] = 100'000;
  const TelemetrySnapshot s = rig.Run();
  EXPECT_EQ(s.worst_latency_ns, 300'000);
  EXPECT_EQ(s.overruns, 0U);
  EXPECT_EQ(s.ticks, 20U);
}

}  // namespace
}  // namespace mrd::firmware
