// Several damper channels on one loop (loop.hpp, channel.hpp): channels that never affect each
// other under FaultPolicy::kChannel (each equals a loop of its own, bit for bit), one channel's
// fault putting every channel safe within two periods under kAll (counted per channel as
// other_channel), and the body law setting inputs between the reads and the updates.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "fakes.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/modal_body_law.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;
constexpr int kPeriods = 1500;
constexpr std::size_t kOther = static_cast<std::size_t>(FaultCause::kOtherChannel);
constexpr std::size_t kNonFiniteCause = static_cast<std::size_t>(FaultCause::kNonFinite);

// Every period's record of one channel.
class Recorder final : public PeriodObserver {
 public:
  void OnPeriod(const PeriodRecord& record) override { records.push_back(record); }
  std::vector<PeriodRecord> records;
};

// One corner: its plant (excitation scaled by `scale`), a fault-injecting source and driver,
// a controller on the demo table, its telemetry and recorder.
// shared: the model of the corners' table, loaded once (nullptr: a copy of its own).
struct Corner {
  Corner(Clock& clock, double scale, std::shared_ptr<const SharedModel> shared = nullptr)
      : plant(SpencerParams::Paper(), Excitation(scale), clock, kPeriod),
        source(plant),
        driver(plant) {
    const ConfigureStatus status =
        shared ? controller.Configure(shared, ControllerConfig{})
               : controller.Configure(test::DemoDamperTable(), ControllerConfig{});
    EXPECT_EQ(status, Error::kOk);
    channel = std::make_unique<Channel>(source, driver, controller, telemetry);
    channel->SetObserver(&recorder);
  }
  static SimulationConfig Excitation(double scale) {
    SimulationConfig c;
    c.amplitude_cm *= scale;
    c.demand_amplitude_n *= scale;
    c.body_amplitude *= scale;
    return c;
  }
  SimulatedDamper plant;
  test::FaultySource source;
  test::FaultyDriver driver;
  Controller controller;
  Telemetry telemetry;
  Recorder recorder;
  std::unique_ptr<Channel> channel;
};

struct Vehicle {
  explicit Vehicle(std::size_t n, std::shared_ptr<const SharedModel> shared = nullptr) {
    for (std::size_t i = 0; i < n; ++i) {
      corners.push_back(
          std::make_unique<Corner>(clock, 1.0 - 0.15 * static_cast<double>(i), shared));
      channels.push_back(corners.back()->channel.get());
    }
  }
  void Run(FaultPolicy policy, BodyLaw* law = nullptr) {
    Loop loop(clock, channels.data(), channels.size(), policy, kPeriod);
    loop.SetBodyLaw(law);
    for (int k = 0; k < kPeriods; ++k) {
      clock.Advance(kPeriod);
      loop.Tick(clock.Now());
    }
    loop.Shutdown();
  }
  const std::vector<PeriodRecord>& records(std::size_t i) const {
    return corners[i]->recorder.records;
  }
  const WatchdogCounters& watchdog(std::size_t i) const {
    return corners[i]->channel->stats().watchdog;
  }
  LockstepClock clock;
  std::vector<std::unique_ptr<Corner>> corners;
  std::vector<Channel*> channels;
};

void ExpectSameCommands(const std::vector<PeriodRecord>& a, const std::vector<PeriodRecord>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].command_v, b[k].command_v) << "period " << k;
    ASSERT_EQ(a[k].safe, b[k].safe) << "period " << k;
    ASSERT_EQ(a[k].model_force, b[k].model_force) << "period " << k;
  }
}

// Channel i alone on a loop of its own (the one-channel constructor).
std::vector<PeriodRecord> Alone(std::size_t i) {
  Vehicle one(0);
  auto corner = std::make_unique<Corner>(one.clock, 1.0 - 0.15 * static_cast<double>(i));
  Loop loop(one.clock, corner->source, corner->driver, corner->controller, corner->telemetry,
            kPeriod);
  loop.SetObserver(&corner->recorder);
  for (int k = 0; k < kPeriods; ++k) {
    one.clock.Advance(kPeriod);
    loop.Tick(one.clock.Now());
  }
  return corner->recorder.records;
}

TEST(ChannelsTest, EachOfFourChannelsEqualsALoopOfItsOwn) {
  for (const FaultPolicy policy : {FaultPolicy::kChannel, FaultPolicy::kAll}) {
    Vehicle car(4);
    car.Run(policy);
    for (std::size_t i = 0; i < 4; ++i) {
      SCOPED_TRACE(i);
      ExpectSameCommands(car.records(i), Alone(i));
      EXPECT_FALSE(car.records(i).back().safe);
      EXPECT_EQ(car.watchdog(i).active_periods[kOther], 0u);
    }
  }
}

TEST(ChannelsTest, FourChannelsOnOneSharedModelEqualFourCopiesAndHoldOneModel) {
  Error error = Error::kOk;
  const auto shared = SharedModel::Load(test::DemoDamperTable(), &error);
  ASSERT_EQ(error, Error::kOk);
  for (const FaultPolicy policy : {FaultPolicy::kChannel, FaultPolicy::kAll}) {
    Vehicle car(4, shared);
    Vehicle copies(4);
    // Channel 1's fault reaches the others under kAll: the shared model carries no state.
    car.corners[1]->source.nan_velocity = {300, 310};
    copies.corners[1]->source.nan_velocity = {300, 310};
    car.Run(policy);
    copies.Run(policy);
    for (std::size_t i = 0; i < 4; ++i) {
      SCOPED_TRACE(i);
      ExpectSameCommands(car.records(i), copies.records(i));
      EXPECT_EQ(&car.corners[i]->controller.runtime().model(), &shared->model());
      EXPECT_NE(&copies.corners[i]->controller.runtime().model(), &shared->model());
    }
  }
}

// Channel 2's velocity is NaN for reads [kFrom, kTo).
constexpr std::size_t kFrom = 600, kTo = 620;

TEST(ChannelsTest, PolicyAllPutsEveryChannelSafeWithinTwoPeriodsOfOneChannelsFault) {
  Vehicle car(4);
  car.corners[2]->source.nan_velocity = {kFrom, kTo};
  car.Run(FaultPolicy::kAll);
  EXPECT_TRUE(car.records(2)[kFrom].safe);
  for (std::size_t i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    const auto& r = car.records(i);
    EXPECT_FALSE(r[kFrom - 1].safe);
    // Safe within two periods of the fault (its period and the next), and while it lasts
    // (the others one period longer: they learn of its end a period later).
    const std::size_t to = i == 2 ? kTo - 1 : kTo;
    for (std::size_t k = kFrom + 1; k <= to; ++k) {
      ASSERT_TRUE(r[k].safe) << "period " << k;
      ASSERT_EQ(r[k].command_v, 0.0) << "period " << k;
    }
    EXPECT_FALSE(r.back().safe);  // every channel recovers once the fault clears
  }
  // Counted per channel: the faulted one by its own cause, the others as other_channel.
  EXPECT_EQ(car.watchdog(2).active_periods[kNonFiniteCause], kTo - kFrom);
  EXPECT_EQ(car.watchdog(2).active_periods[kOther], 0u);
  for (const std::size_t i : {0, 1, 3}) {
    EXPECT_EQ(car.watchdog(i).active_periods[kOther], kTo - kFrom) << i;
    EXPECT_EQ(car.watchdog(i).trips[kOther], 1u) << i;
    EXPECT_EQ(car.watchdog(i).active_periods[kNonFiniteCause], 0u) << i;
    EXPECT_EQ(car.records(i)[kFrom + 1].causes, Watchdog::Bit(FaultCause::kOtherChannel)) << i;
  }
}

TEST(ChannelsTest, PolicyChannelKeepsTheOtherChannelsCommands) {
  Vehicle faulted(4), clean(4);
  faulted.corners[2]->source.nan_velocity = {kFrom, kTo};
  faulted.Run(FaultPolicy::kChannel);
  clean.Run(FaultPolicy::kChannel);
  for (std::size_t k = kFrom; k < kTo; ++k) ASSERT_TRUE(faulted.records(2)[k].safe) << k;
  for (const std::size_t i : {0, 1, 3}) {
    SCOPED_TRACE(i);
    ExpectSameCommands(faulted.records(i), clean.records(i));
    EXPECT_EQ(faulted.watchdog(i).active_periods[kOther], 0u);
  }
  EXPECT_EQ(faulted.watchdog(2).active_periods[kNonFiniteCause], kTo - kFrom);
}

TEST(ChannelsTest, ADriverFaultOnOneChannelIsPassedOnUnderPolicyAll) {
  Vehicle car(4);
  car.corners[1]->driver.fail_from = kFrom;  // command calls [kFrom, kFrom + 1) fail
  car.corners[1]->driver.fail_to = kFrom + 1;
  car.Run(FaultPolicy::kAll);
  EXPECT_GE(car.watchdog(1).trips[static_cast<std::size_t>(FaultCause::kDriverFault)], 1u);
  for (const std::size_t i : {0, 2, 3}) {
    EXPECT_EQ(car.watchdog(i).trips[kOther], 1u) << i;
    EXPECT_EQ(car.watchdog(i).trips[static_cast<std::size_t>(FaultCause::kDriverFault)], 0u);
  }
}

// Swaps channels 0 and 1's force demands: the law runs after every read, before any update.
class SwapDemands final : public BodyLaw {
 public:
  void Apply(SensorFrame* const* frames, std::size_t n, std::int64_t now_ns) override {
    ASSERT_EQ(n, 2u);
    last_now_ns = now_ns;
    std::swap((*frames[0])[Input::kDemand], (*frames[1])[Input::kDemand]);
  }
  std::int64_t last_now_ns = 0;
};

TEST(ChannelsTest, TheBodyLawSetsInputsBetweenTheReadsAndTheUpdates) {
  Vehicle swapped(2), plain(2);
  SwapDemands law;
  swapped.Run(FaultPolicy::kChannel, &law);
  plain.Run(FaultPolicy::kChannel);
  EXPECT_EQ(law.last_now_ns, kPeriods * kPeriod);
  const auto& a = swapped.records(0);
  const auto& b = plain.records(1);
  for (std::size_t k = 0; k < a.size(); k += 97) {
    EXPECT_EQ(a[k].frame[Input::kDemand].value, b[k].frame[Input::kDemand].value) << k;
  }
  EXPECT_NE(a[300].force_demand, plain.records(0)[300].force_demand);
}

// Modal skyhook over four corners: each channel's demand is the law's on the four body
// velocities read that period, and one corner's stalled sensor makes every demand stale.
TEST(ChannelsTest, ModalSkyhookSetsEachCornersDemandFromAllFourBodyVelocities) {
  ModalSkyhook modal;
  ASSERT_EQ(modal.Configure(BodyGeometry{}, ModalGains{}), Error::kOk);
  ModalBodyLaw law(modal);
  Vehicle car(4);
  car.corners[3]->source.stall = {kFrom, kTo};
  car.Run(FaultPolicy::kChannel, &law);
  for (std::size_t k = 1; k < kFrom; k += 53) {
    double body[kModalCorners], demand[kModalCorners];
    for (int i = 0; i < kModalCorners; ++i) {
      body[i] = car.records(i)[k].frame[Input::kBodyVelocity].value;
    }
    modal.Demands(body, demand);
    for (int i = 0; i < kModalCorners; ++i) {
      ASSERT_EQ(car.records(i)[k].frame[Input::kDemand].value, demand[i]) << k << " " << i;
    }
  }
  EXPECT_NE(car.records(0)[300].frame[Input::kDemand].value,
            car.records(1)[300].frame[Input::kDemand].value);
  // The stall outlasts the sensors' age limit (5 ms): every corner's demand goes stale.
  constexpr std::size_t kStale = static_cast<std::size_t>(FaultCause::kStaleSensor);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_TRUE(car.records(i)[kTo - 1].safe) << i;
    EXPECT_EQ(car.watchdog(i).trips[kStale], 1u) << i;
    EXPECT_FALSE(car.records(i).back().safe) << i;
  }
}

// A loop built on no channel, on more than kMaxChannels, on a null channel or on a period <= 0
// is not ok: it holds no channel and runs nothing (no channel is read or commanded).
void ExpectRefused(Loop& loop, Vehicle& car) {
  EXPECT_FALSE(loop.ok());
  EXPECT_EQ(loop.channel_count(), 0u);
  for (int k = 0; k < 5; ++k) {
    car.clock.Advance(kPeriod);
    loop.Tick(car.clock.Now());
  }
  const std::atomic<bool> stop{false};
  loop.Run(stop, 5 * kPeriod);
  loop.Shutdown();
  EXPECT_EQ(loop.stats().ticks, 0u);
  for (std::size_t i = 0; i < car.corners.size(); ++i) {
    EXPECT_TRUE(car.records(i).empty()) << i;
    EXPECT_EQ(car.corners[i]->channel->stats().ticks, 0u) << i;
  }
}

TEST(ChannelsTest, ALoopOnNoneOrMoreThanEightOrANullChannelIsNotOk) {
  Vehicle nine(9);
  Loop too_many(nine.clock, nine.channels.data(), nine.channels.size(), FaultPolicy::kAll, kPeriod);
  ExpectRefused(too_many, nine);
  Vehicle none(0);
  Loop empty(none.clock, none.channels.data(), 0, FaultPolicy::kAll, kPeriod);
  ExpectRefused(empty, none);
  Vehicle two(2);
  std::array<Channel*, 2> holed{two.channels[0], nullptr};
  Loop with_null(two.clock, holed.data(), holed.size(), FaultPolicy::kAll, kPeriod);
  ExpectRefused(with_null, two);
  Loop no_period(two.clock, two.channels.data(), two.channels.size(), FaultPolicy::kAll, 0);
  ExpectRefused(no_period, two);
  Loop one_no_period(two.clock, two.corners[0]->source, two.corners[0]->driver,
                     two.corners[0]->controller, two.corners[0]->telemetry, -1);
  ExpectRefused(one_no_period, two);
  Vehicle eight(kMaxChannels);
  Loop full(eight.clock, eight.channels.data(), eight.channels.size(), FaultPolicy::kAll, kPeriod);
  EXPECT_TRUE(full.ok());
  EXPECT_EQ(full.channel_count(), kMaxChannels);
}

}  // namespace
}  // namespace mrd::firmware
