// What the inversion commands for a semi-active damper (inverter.hpp), against a brute-force
// search over a fine grid of E: a demand of 0 N or against v gives E_min; any other demand the
// LEAST E whose force is nearest it, on the force the damper can be relied on to give at that
// E or below (the running maximum: a model's dip in E is not used); the monotony verdict. First on
// random states of every model the tests ship and of one deliberately non-monotone in E, then
// through the loop on a quarter car, where the loop's counters must equal what the brute force
// finds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/inverter.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "mrd/sim/quarter_car.hpp"
#include "reference_models.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr int kGrid = 20000;  // grid intervals over [E_min, E_max]

// The brute force at one state, for a dissipative demand f at velocity v != 0: on the grid, the
// force in v's direction z = sign(v) f(E) and its running maximum g (what the damper can be
// relied on to give at E or below).
struct Brute {
  bool reachable = false;  // g(E_min) <= the demand <= max g
  // Where the least E of the nearest force lies: [E_min, E_min] when the demand is at or below
  // g(E_min); reachable: the grid interval where g first reaches the demand; else around the
  // first grid E where g is largest (the true maximum within a grid step either side).
  double e = 0.0, e_hi = 0.0;
  bool monotone = true;  // no grid force beyond the end forces by kMonotoneSlack of their
                         // difference
};

// force(E): the model force [N] at the state.
template <class Force>
Brute BruteForce(const Force& force, double f, double v, double lo, double hi) {
  const double s = v > 0.0 ? 1.0 : -1.0, u = s * f;
  std::vector<double> e(kGrid + 1), y(kGrid + 1), g(kGrid + 1);
  for (std::size_t i = 0; i < e.size(); ++i) {
    e[i] = lo + (hi - lo) * static_cast<double>(i) / kGrid;
    y[i] = force(e[i]);
    g[i] = i == 0 ? s * y[i] : std::max(g[i - 1], s * y[i]);
  }
  Brute b;
  b.reachable = u >= g.front() && u <= g.back();
  if (u <= g.front()) {
    b.e = b.e_hi = lo;
  } else {
    for (std::size_t i = 0; i < g.size(); ++i) {
      if (g[i] >= std::min(u, g.back())) {
        b.e = e[i == 0 ? 0 : i - 1];
        b.e_hi = b.reachable ? e[i] : e[std::min(i + 1, g.size() - 1)];
        break;
      }
    }
  }
  const auto [bottom, top] = std::minmax_element(y.begin(), y.end());
  const double span = std::fabs(y.back() - y.front());
  b.monotone = !(*top - *bottom > span * (1.0 + Inverter::kMonotoneSlack));
  return b;
}

bool Passive(double f, double v) { return f == 0.0 || f * v < 0.0; }

// Random states and demands (a quarter of them 0 N) on one model.
void CheckRandomStates(const CoefficientTable& table, const char* name, int* non_monotone) {
  BasicModelRuntime<double> rt;
  BasicInverter<double> inv;
  ASSERT_EQ(rt.Configure(table), Error::kOk) << name;
  ASSERT_EQ(inv.Configure(table), Error::kOk) << name;
  const double lo = inv.e_min(), hi = inv.e_max();
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> vel(-15.0, 15.0), volt(lo, hi), demand(-2500.0, 2500.0);
  int mismatches = 0;
  for (int trial = 0; trial < 400; ++trial) {
    rt.Reset();
    for (int k = 0; k < 20; ++k) rt.Step(vel(rng), 0.0, volt(rng));
    const double v = vel(rng);
    rt.Begin(v, 0.0);
    const double f = trial % 4 == 0 ? 0.0 : demand(rng);
    const auto s = inv.Solve(rt.history(), f, v);
    const Brute b = BruteForce([&](double E) { return rt.ForceAt(E); }, f, v, lo, hi);
    EXPECT_EQ(s.passive, Passive(f, v)) << name << " trial " << trial;
    if (s.monotone != b.monotone) ++mismatches;
    if (!b.monotone) ++*non_monotone;
    if (Passive(f, v)) {
      EXPECT_EQ(s.E, lo) << name << " trial " << trial << " f " << f << " v " << v;
      continue;
    }
    EXPECT_EQ(s.reachable, b.reachable) << name << " trial " << trial;
    // Within the grid interval where g first reaches the demand (or its largest value).
    EXPECT_GE(s.E, b.e - 1e-12) << name << " trial " << trial << " f " << f << " v " << v;
    EXPECT_LE(s.E, b.e_hi + 1e-12) << name << " trial " << trial << " f " << f << " v " << v;
    if (b.reachable) {
      EXPECT_NEAR(rt.ForceAt(s.E), f, 1e-6 * std::max(1.0, std::fabs(f))) << name;
    }
  }
  EXPECT_EQ(mismatches, 0) << name << ": monotony verdicts differing from the brute force";
}

TEST(InversionSemanticsTest, LeastEOfTheNearestForceOnEveryModel) {
  int non_monotone = 0;
  CheckRandomStates(kBuiltinTable, "built-in", &non_monotone);
  CheckRandomStates(test::DemoDamperTable(), "demo", &non_monotone);
  CheckRandomStates(test::QuarticTable(), "quartic", &non_monotone);
  CheckRandomStates(test::MonotoneTable(), "monotone", &non_monotone);
  CheckRandomStates(test::LowPassTable(), "low-pass", &non_monotone);
  int deliberate = 0;
  CheckRandomStates(test::NonMonotoneTable(), "non-monotone", &deliberate);
  // The deliberately non-monotone model is so on part of its states (|v| > 6 cm/s), not all.
  EXPECT_GT(deliberate, 100);
  EXPECT_LT(deliberate, 350);
}

// A zero or non-dissipative demand gives E_min even where the model gives less force at E_max
// (the non-monotone model at |v| = 15 cm/s: +75 N at 0 V, -75 N at 2.25 V).
TEST(InversionSemanticsTest, ZeroOrActiveDemandGivesEMinWhateverTheModel) {
  BasicModelRuntime<double> rt;
  BasicInverter<double> inv;
  ASSERT_EQ(rt.Configure(test::NonMonotoneTable()), Error::kOk);
  ASSERT_EQ(inv.Configure(test::NonMonotoneTable()), Error::kOk);
  rt.Begin(15.0, 0.0);
  ASSERT_NEAR(rt.ForceAt(0.0), 75.0, 1e-9);
  ASSERT_NEAR(rt.ForceAt(2.25), -75.0, 1e-9);
  for (const double f : {0.0, -10.0, -75.0, -1000.0}) {
    const auto s = inv.Solve(rt.history(), f, 15.0);
    EXPECT_EQ(s.E, 0.0) << f;
    EXPECT_TRUE(s.passive) << f;
    EXPECT_FALSE(s.monotone);
  }
  // The force peaks at 0.4 of the range (0.9 V, 195 N). 10 N, below 0 V's 75 N, only the
  // falling branch gives: not used (never a stiffer setting for less force), E_min.
  const auto small = inv.Solve(rt.history(), 10.0, 15.0);
  EXPECT_EQ(small.E, 0.0);
  EXPECT_FALSE(small.reachable);
  EXPECT_FALSE(small.passive);
  // 150 N: on the rising branch, below the peak.
  const auto mid = inv.Solve(rt.history(), 150.0, 15.0);
  EXPECT_TRUE(mid.reachable);
  EXPECT_LT(mid.E, 0.9);
  EXPECT_NEAR(rt.ForceAt(mid.E), 150.0, 1e-9);
  // 300 N, beyond the peak: the peak, not E_max.
  const auto big = inv.Solve(rt.history(), 300.0, 15.0);
  EXPECT_FALSE(big.reachable);
  EXPECT_NEAR(big.E, 0.9, 1e-9);
}

// The quarter car on a class C road at 20 m/s with skyhook on the non-monotone model (the plant
// is the reference damper): the loop's counters against the brute force at every period.
class PlantSource final : public SensorSource {
 public:
  PlantSample sample;
  IoStatus Read(const IoTime& t, SensorFrame* frame) override {
    (*frame)[Input::kVelocity] = {sample.v, t.loop_ns};
    (*frame)[Input::kDisplacement] = {sample.x, t.loop_ns};
    (*frame)[Input::kBodyVelocity] = {sample.body_velocity, t.loop_ns};
    (*frame)[Input::kForce] = {sample.force, t.loop_ns};
    return IoStatus::kOk;
  }
};
class HeldDriver final : public CurrentDriver {
 public:
  double volts = 0.0;
  IoStatus Command(const IoTime&, double v) override {
    volts = v;
    return IoStatus::kOk;
  }
  IoStatus EnterSafeState(const IoTime&, double v) override {
    volts = v;
    return IoStatus::kOk;
  }
};
class Records final : public PeriodObserver {
 public:
  PeriodRecord last;
  void OnPeriod(const PeriodRecord& r) override { last = r; }
};

TEST(InversionSemanticsTest, QuarterCarSkyhookOnANonMonotoneModel) {
  constexpr std::int64_t kPeriod = 1'000'000;
  const CoefficientTable table = test::NonMonotoneTable();
  ControllerConfig config;
  config.law.mode = ControlMode::kSkyhookContinuous;
  config.law.skyhook_gain = 60.0;
  config.law.force_limit = 1500.0;
  Controller controller;
  ASSERT_EQ(controller.Configure(table, config), Error::kOk);
  ModelRuntime mirror;  // the controller's model, for the brute force at each period's state
  ASSERT_EQ(mirror.Configure(table), Error::kOk);
  RoadParams road;
  road.road_class = RoadClass::kC;
  QuarterCarParams car;
  car.speed_m_s = 20.0;
  QuarterCarPlant plant(SpencerParams::Paper(), car, road, 1e-3);
  LockstepClock clock;
  PlantSource source;
  HeldDriver driver;
  Telemetry telemetry;
  Loop loop(clock, source, driver, controller, telemetry, kPeriod);
  Records records;
  loop.SetObserver(&records);

  std::uint64_t passive = 0, passive_stiff = 0, unreachable = 0, non_monotone = 0, active = 0;
  source.sample = plant.Sample();
  for (int k = 0; k < 10000; ++k) {
    clock.Advance(kPeriod);
    mirror.Begin(static_cast<Real>(source.sample.v), static_cast<Real>(source.sample.x));
    loop.Tick(clock.Now());
    const PeriodRecord& r = records.last;
    ASSERT_EQ(r.v_used, source.sample.v);  // the model ran on the velocity the mirror did
    if (r.force_law) {
      const auto force = [&](double E) {
        return static_cast<double>(mirror.ForceAt(static_cast<Real>(E)));
      };
      const Brute b = BruteForce(force, r.force_demand, r.v_used, 0.0, 2.25);
      if (!b.monotone) ++non_monotone;
      if (Passive(r.force_demand, r.v_used)) {
        ++passive;
        if (r.command_v > 0.1) ++passive_stiff;
      } else {
        ++active;
        if (!b.reachable) ++unreachable;
      }
    }
    mirror.Finish(static_cast<Real>(r.command_v));
    source.sample = plant.Step(driver.volts);
  }
  const TelemetrySnapshot s = telemetry.Read();
  std::printf(
      "[ figures ] %llu passive demands (%llu commanded above E_min + 0.1 V), %llu "
      "others (%llu unreachable); %llu non-monotone periods\n",
      static_cast<unsigned long long>(passive), static_cast<unsigned long long>(passive_stiff),
      static_cast<unsigned long long>(active), static_cast<unsigned long long>(unreachable),
      static_cast<unsigned long long>(non_monotone));
  // The run exercises what it checks: many zero demands, non-monotone states and both kinds of
  // dissipative demand.
  EXPECT_GT(passive, 2000U);
  EXPECT_GT(non_monotone, 500U);
  EXPECT_GT(active, 1000U);
  EXPECT_GT(unreachable, 10U);
  EXPECT_LT(unreachable, active);
  EXPECT_EQ(passive_stiff, 0U);
  EXPECT_EQ(s.passive_demands, passive);
  EXPECT_EQ(s.unreachable, unreachable);
  EXPECT_EQ(s.non_monotone, non_monotone);
}

}  // namespace
}  // namespace mrd::firmware
