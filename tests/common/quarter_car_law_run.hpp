#pragma once
// A firmware law on the quarter car in process at 1 kHz: the plant's sample (every routed input
// fresh, stamped now) feeds Controller::Update; its command is held over the next period (no
// transport, no added delay). 25 s per run, the first 2 s (start-up transient) not scored.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/sim/quarter_car.hpp"

namespace mrd::test {

inline constexpr double kLawPeriod = 1e-3;    // [s]
inline constexpr double kLawDuration = 25.0;  // [s]
inline constexpr double kLawSettle = 2.0;     // [s]

struct LawRun {
  RideMetrics ride;
  std::uint64_t violations = 0;    // command non-finite or outside [0, E_max]
  std::uint64_t safe_periods = 0;  // watchdog safe state after the first period
  double mean_volts = 0.0;         // [V]
};

// Runs the law on the plant from Reset.
inline LawRun RunLaw(QuarterCarPlant* plant, const firmware::ControlLawConfig& law) {
  firmware::ControllerConfig config;
  config.law = law;
  firmware::Controller controller;
  EXPECT_EQ(controller.Configure(firmware::kBuiltinTable, config), Error::kOk);
  plant->Reset();
  LawRun run;
  const auto steps = static_cast<std::int64_t>(std::llround(kLawDuration / kLawPeriod));
  for (std::int64_t k = 0; k < steps; ++k) {
    const PlantSample s = plant->Sample();
    const std::int64_t now = k * 1'000'000;  // [ns]
    firmware::SensorFrame frame;
    frame[firmware::Input::kVelocity] = {s.v, now};
    frame[firmware::Input::kDisplacement] = {s.x, now};
    frame[firmware::Input::kBodyVelocity] = {s.body_velocity, now};
    frame[firmware::Input::kWheelVelocity] = {s.wheel_velocity, now};
    frame[firmware::Input::kBodyAcceleration] = {s.body_acceleration, now};
    frame[firmware::Input::kForce] = {s.force, now};
    const firmware::ControllerOutput out =
        controller.Update(frame, firmware::IoStatus::kOk, false, now, kLawPeriod);
    if (!std::isfinite(out.volts) || out.volts < 0.0 || out.volts > config.e_max) {
      ++run.violations;
    }
    if (out.safe && k > 0) ++run.safe_periods;
    run.mean_volts += out.volts / static_cast<double>(steps);
    plant->Step(out.volts);
    if (plant->Detail().plant.t_s > kLawSettle) run.ride.Add(plant->Detail());
  }
  return run;
}

}  // namespace mrd::test
