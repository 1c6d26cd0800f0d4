// Conformance (labels conformance, firmware): the displacement limit holds whenever a
// displacement is measured, also when neither the model nor the velocity reads it (the
// compiled-in table reads v and E only), and a config that sets a limit no bus can measure is
// refused; a model whose force turns non-finite is a watchdog cause (non_finite), not a
// silent reset.
#include <gtest/gtest.h>

#include <cstddef>
#include <string>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kMs = 1'000'000;  // [ns]
constexpr double kDt = 1e-3;             // [s]
constexpr std::uint32_t kImplausible = Watchdog::Bit(FaultCause::kImplausible);
constexpr std::uint32_t kNonFinite = Watchdog::Bit(FaultCause::kNonFinite);

SensorFrame Fresh(std::int64_t now_ns, double x) {
  SensorFrame f;
  f[Input::kVelocity] = {3.0, now_ns};
  f[Input::kDisplacement] = {x, now_ns};
  f[Input::kDemand] = {200.0, now_ns};
  return f;
}

std::size_t Idx(FaultCause c) { return static_cast<std::size_t>(c); }

TEST(DisplacementLimitConformance, HoldsWhenTheModelDoesNotReadTheDisplacement) {
  ControllerConfig config;
  config.displacement_limit = 5.0;  // [cm]
  Controller c;
  ASSERT_EQ(c.Configure(kBuiltinTable, config), Error::kOk);
  ASSERT_FALSE(c.runtime().reads_displacement());  // the case of the defect
  std::int64_t t = 10 * kMs;
  ControllerOutput out = c.Update(Fresh(t, 4.9), IoStatus::kOk, false, t, kDt);
  EXPECT_FALSE(out.safe);
  EXPECT_EQ(out.causes, 0U);
  for (const double x : {5.1, 51.0, 510.0, 5100.0, -5.1}) {
    t += kMs;
    out = c.Update(Fresh(t, x), IoStatus::kOk, false, t, kDt);
    EXPECT_TRUE(out.safe) << x << " cm";
    EXPECT_EQ(out.causes, kImplausible) << x << " cm";
    EXPECT_EQ(out.volts, config.safe_voltage) << x << " cm";
  }
  t += kMs;
  EXPECT_FALSE(c.Update(Fresh(t, 5.0), IoStatus::kOk, false, t, kDt).safe);  // recovers
  EXPECT_EQ(c.watchdog().counters().trips[Idx(FaultCause::kImplausible)], 1U);
}

TEST(DisplacementLimitConformance, UnmeasuredDisplacementIsNoCause) {
  ControllerConfig config;
  config.displacement_limit = 5.0;
  Controller c;
  ASSERT_EQ(c.Configure(kBuiltinTable, config), Error::kOk);
  SensorFrame f = Fresh(10 * kMs, 0.0);
  f[Input::kDisplacement] = Stamped{};  // no bus serves it: never sampled, not required
  EXPECT_EQ(c.Update(f, IoStatus::kOk, false, 10 * kMs, kDt).causes, 0U);
}

TEST(DisplacementLimitConformance, ConfigRefusesALimitNoBusCanMeasure) {
  const auto parse = [](const std::string& text, std::string* error) {
    platform::FirmwareConfig c;
    return platform::ParseConfig(text, "fw.toml", &c, error);
  };
  const std::string buses =
      "[can]\nlocal_bus = \"/tmp/bus\"\ninputs = [\"velocity\", \"demand\"]\n"
      "outputs = [\"command\"]\n";
  std::string error;
  EXPECT_FALSE(parse("[safety]\ndisplacement_limit = 5\n" + buses, &error));
  EXPECT_EQ(error.rfind("fw.toml:2: ", 0), 0U) << error;
  EXPECT_NE(error.find("input 'displacement'"), std::string::npos) << error;
  // Served by the bus: accepted; no limit: accepted; dry run (the simulated damper measures x).
  const std::string with_x =
      "[can]\nlocal_bus = \"/tmp/bus\"\ninputs = [\"velocity\", \"demand\", \"displacement\"]\n"
      "outputs = [\"command\"]\n";
  EXPECT_TRUE(parse("[safety]\ndisplacement_limit = 5\n" + with_x, &error)) << error;
  EXPECT_TRUE(parse("[safety]\ndisplacement_limit = 0\n" + buses, &error)) << error;
  EXPECT_TRUE(parse("[safety]\ndisplacement_limit = 5\n", &error)) << error;
}

// The demo model (tests/support/demo_model.hpp, no envelope to hold the force) with its f(k-1)
// coefficient 0.85 -> 1e6: the force grows by 1e6 per period until it overflows (about 50
// periods in double, 6 in float), the model is reset and it starts over: non-finite again and
// again.
TEST(ModelDivergenceConformance, ANonFiniteModelForceIsAWatchdogCause) {
  CoefficientTable table = mrd::test::DemoDamperTable();
  table.model.coefficients[0] = 1e6;
  ControllerConfig config;
  config.law.mode = ControlMode::kConstantVoltage;
  config.law.constant_voltage = 1.0;
  Controller c;
  ASSERT_EQ(c.Configure(table, config), Error::kOk);
  std::int64_t t = 10 * kMs;
  std::uint64_t resets = 0;
  int after_reset = 0, safe_after_reset = 0;
  for (int k = 0; k < 1000; ++k, t += kMs) {
    const ControllerOutput out = c.Update(Fresh(t, 0.0), IoStatus::kOk, false, t, kDt);
    if (c.model_resets() == resets && resets > 0 && (out.causes & kNonFinite) != 0) {
      ++after_reset;  // the period after a reset (the model was finite again in it)
      if (out.safe && out.volts == config.safe_voltage) ++safe_after_reset;
    }
    resets = c.model_resets();
  }
  ASSERT_GE(c.model_resets(), 5U) << "the model should diverge repeatedly";
  const WatchdogCounters& w = c.watchdog().counters();
  // One non_finite episode per divergence: the period after each reset is safe.
  EXPECT_EQ(w.trips[Idx(FaultCause::kNonFinite)], c.model_resets());
  EXPECT_GE(w.active_periods[Idx(FaultCause::kNonFinite)], c.model_resets());
  EXPECT_GE(w.safe_periods, c.model_resets());
  EXPECT_GE(after_reset, 1);
  EXPECT_EQ(safe_after_reset, after_reset);
  // A clean model is no cause: the compiled-in table over the same 1000 periods.
  Controller clean;
  ASSERT_EQ(clean.Configure(kBuiltinTable, config), Error::kOk);
  for (int k = 0; k < 1000; ++k, t += kMs)
    clean.Update(Fresh(t, 0.0), IoStatus::kOk, false, t, kDt);
  EXPECT_EQ(clean.model_resets(), 0U);
  EXPECT_EQ(clean.watchdog().counters().trips[Idx(FaultCause::kNonFinite)], 0U);
}

}  // namespace
}  // namespace mrd::firmware
