// The chassis laws (groundhook, groundhook-on-off, hybrid, add, sh-add) against skyhook and the
// passive cases on the quarter car: ISO 8608 class C road at 20 m/s, in process at 1 kHz (the
// plant's sample feeds Controller::Update, its command is held over the next period; no
// transport). Default QuarterCarParams, Spencer "paper" damper, compiled-in NARX table, 25 s
// per run, the first 2 s not scored. Figures are printed (docs/benchmarks.md quotes them).
//
// Asserted: every law keeps its command finite and in [0, E_max] and never trips the
// watchdog; the comfort laws (add, sh-add, hybrid at alpha 1 = skyhook) ride below passive-on;
// sh-add rides below passive-off (the comfort claim of Savaresi & Spelta 2007); groundhook
// (a road-holding law) keeps the tyre load RMS below passive-off's.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/sim/quarter_car.hpp"
#include "quarter_car_law_run.hpp"

namespace mrd {
namespace {

using firmware::ControlMode;

constexpr double kPeriod = test::kLawPeriod;      // [s]
constexpr double kDuration = test::kLawDuration;  // [s]
constexpr double kSettle = test::kLawSettle;      // [s]

using test::LawRun;
using test::RunLaw;

QuarterCarPlant MakePlant(std::uint64_t seed) {
  RoadParams road;
  road.road_class = RoadClass::kC;
  road.seed = seed;
  return QuarterCarPlant(SpencerParams::Paper(), QuarterCarParams{}, road, kPeriod);
}

void Print(const char* name, const RideMetrics& m, const RideMetrics& off, double volts) {
  std::printf(
      "  %-28s body acc RMS %.4f m/s^2 (%+6.1f %%)  travel RMS %.3f cm  tyre load RMS "
      "%6.1f N (%+6.1f %%)  mean E %.3f V\n",
      name, m.body_accel_rms(), 100.0 * (m.body_accel_rms() / off.body_accel_rms() - 1.0),
      m.travel_rms_cm(), m.tyre_load_rms_n(),
      100.0 * (m.tyre_load_rms_n() / off.tyre_load_rms_n() - 1.0), volts);
}

// The shipped gains (hil/scenarios/quarter-car-<law>.toml use the same).
firmware::ControlLawConfig Law(ControlMode mode) {
  firmware::ControlLawConfig c;
  c.mode = mode;
  c.skyhook_gain = 60.0;     // [N s/cm] (quarter_car_skyhook_test.cpp)
  c.groundhook_gain = 20.0;  // [N s/cm]
  c.hybrid_gain = 60.0;      // [N s/cm]
  c.hybrid_alpha = 0.8;
  c.sh_add_alpha = 9.42;  // [rad/s] = 2 pi 1.5 Hz
  return c;
}

TEST(QuarterCarChassisLawTest, EachLawAgainstPassiveOnClassC) {
  const ControlMode modes[] = {
      ControlMode::kSkyhookContinuous, ControlMode::kSkyhookOnOff, ControlMode::kGroundhook,
      ControlMode::kGroundhookOnOff,   ControlMode::kHybrid,       ControlMode::kAdd,
      ControlMode::kSkyhookAdd};
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    QuarterCarPlant plant = MakePlant(seed);
    const RideMetrics off = RunConstantVoltage(&plant, 0.0, kDuration, kSettle);
    const RideMetrics on = RunConstantVoltage(&plant, 2.25, kDuration, kSettle);
    std::printf(
        "class C, 20 m/s, %.0f s (scored after %.0f s), road seed %llu "
        "(%%: against passive-off):\n",
        kDuration, kSettle, static_cast<unsigned long long>(seed));
    Print("passive-off (0 V)", off, off, 0.0);
    Print("passive-on (2.25 V)", on, off, 2.25);
    for (const ControlMode mode : modes) {
      SCOPED_TRACE(firmware::ControlModeName(mode));
      const LawRun run = RunLaw(&plant, Law(mode));
      Print(firmware::ControlModeName(mode), run.ride, off, run.mean_volts);
      EXPECT_EQ(run.violations, 0U);
      EXPECT_EQ(run.safe_periods, 0U);
      EXPECT_EQ(run.ride.count(), off.count());
      const double acc = run.ride.body_accel_rms();
      if (mode == ControlMode::kAdd || mode == ControlMode::kSkyhookAdd ||
          mode == ControlMode::kHybrid) {
        EXPECT_LT(acc, on.body_accel_rms()) << "seed " << seed;
      }
      if (mode == ControlMode::kSkyhookAdd) {
        EXPECT_LT(acc, off.body_accel_rms()) << "seed " << seed;
      }
      if (mode == ControlMode::kGroundhook) {
        EXPECT_LT(run.ride.tyre_load_rms_n(), off.tyre_load_rms_n()) << "seed " << seed;
      }
    }
  }
}

// Gains and blends, printed (seed 1): how the shipped values were chosen. Asserted: hybrid at
// alpha 1 is skyhook.
TEST(QuarterCarChassisLawTest, GainSweep) {
  QuarterCarPlant plant = MakePlant(1);
  const RideMetrics off = RunConstantVoltage(&plant, 0.0, kDuration, kSettle);
  std::printf("sweep, class C, 20 m/s, seed 1 (%%: against passive-off):\n");
  char name[64];
  for (const double gain : {5.0, 10.0, 20.0, 40.0, 80.0}) {
    firmware::ControlLawConfig c = Law(ControlMode::kGroundhook);
    c.groundhook_gain = gain;
    const LawRun run = RunLaw(&plant, c);
    std::snprintf(name, sizeof name, "groundhook c=%.0f", gain);
    Print(name, run.ride, off, run.mean_volts);
  }
  for (const double alpha : {0.0, 0.25, 0.5, 0.8, 1.0}) {
    firmware::ControlLawConfig c = Law(ControlMode::kHybrid);
    c.hybrid_alpha = alpha;
    const LawRun run = RunLaw(&plant, c);
    std::snprintf(name, sizeof name, "hybrid c=60 alpha=%.2f", alpha);
    Print(name, run.ride, off, run.mean_volts);
    if (alpha == 1.0) {  // the blend's skyhook end is skyhook at the same gain, period for period
      const LawRun sky = RunLaw(&plant, Law(ControlMode::kSkyhookContinuous));
      EXPECT_DOUBLE_EQ(run.ride.body_accel_rms(), sky.ride.body_accel_rms());
    }
  }
  for (const double hz : {0.5, 1.0, 1.5, 2.5, 4.0}) {
    firmware::ControlLawConfig c = Law(ControlMode::kSkyhookAdd);
    c.sh_add_alpha = 2.0 * 3.14159265358979 * hz;
    const LawRun run = RunLaw(&plant, c);
    std::snprintf(name, sizeof name, "sh-add alpha=2pi*%.1f Hz", hz);
    Print(name, run.ride, off, run.mean_volts);
  }
}

}  // namespace
}  // namespace mrd
