// The firmware's clipped-optimal law through its Controller (labels firmware, control): in
// closed loop with the structure plant, fed the exact floor accelerations and force each
// period, it gives the in-process study's clipped-optimal response to the last digit (the same
// observer, rule and timing: measure, command, hold for the period); the inverse command runs
// the same loop within the damper's range.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/platform/clipped_optimal_file.hpp"
#include "mrd/hil/plants/structure_plant.hpp"
#include "mrd/hil/plants/structure_scores.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/structure/study.hpp"

namespace mrd {
namespace {

const std::string kScenario =
    std::string(MRD_SOURCE_DIR) + "/hil/scenarios/structure-clipped-optimal.toml";
const std::string kRecord = std::string(MRD_SOURCE_DIR) + "/hil/data/el_centro_1940_ns.csv";
const std::string kGains = std::string(MRD_SOURCE_DIR) + "/hil/data/clipped_optimal_gains.toml";

struct LoopResult {
  hil::StructureFigures figures;
  std::uint64_t safe_periods = 0, force_law_periods = 0;
  double mean_volts = 0.0;
};

LoopResult RunLoop(firmware::ClippedCommand command) {
  hil::Scenario s;
  std::string error;
  EXPECT_TRUE(hil::LoadScenario(kScenario, &s, &error)) << error;
  firmware::ControllerConfig config;
  config.law.mode = firmware::ControlMode::kClippedOptimal;
  config.law.clipped_command = command;
  EXPECT_TRUE(firmware::platform::LoadClippedOptimalGains(kGains, &config.clipped_gains, &error))
      << error;
  config.clipped_gains_loaded = true;
  firmware::Controller controller;
  EXPECT_EQ(controller.Configure(firmware::kBuiltinTable, config), Error::kOk);
  hil::StructurePlant plant(s.structure_setup, s.damper, 1e-3, s.substeps);
  hil::StructureMetrics m;
  LoopResult r;
  PlantSample p = plant.Sample();
  double sum_v = 0.0;
  constexpr std::int64_t kMs = 1'000'000;
  for (std::int64_t k = 0; k < 7236; ++k) {
    const std::int64_t now = (k + 1) * kMs;
    firmware::SensorFrame f;
    f[firmware::Input::kVelocity] = {p.v, now};
    f[firmware::Input::kDisplacement] = {p.x, now};
    f[firmware::Input::kForce] = {p.force, now};
    for (int i = 0; i < 3; ++i) f[firmware::FloorAcceleration(i)] = {p.floor_acceleration[i], now};
    const firmware::ControllerOutput out =
        controller.Update(f, firmware::IoStatus::kOk, false, now, 1e-3);
    if (out.safe) ++r.safe_periods;
    if (out.force_law) ++r.force_law_periods;
    sum_v += out.volts;
    p = plant.Step(out.volts);
    m.Add(*plant.Structure());
  }
  r.figures = m.Figures();
  r.mean_volts = sum_v / 7236.0;
  return r;
}

TEST(StructureFirmwareLawTest, TheControllerInClosedLoopIsTheStudysClippedOptimal) {
  const LoopResult loop = RunLoop(firmware::ClippedCommand::kClipped);
  EXPECT_EQ(loop.safe_periods, 0U);
  EXPECT_EQ(loop.force_law_periods, 0U);
  GroundRecord record;
  std::string error;
  ASSERT_TRUE(LoadGroundRecord(kRecord, &record, &error)) << error;
  firmware::ClippedOptimalGains gains;
  ASSERT_TRUE(firmware::platform::LoadClippedOptimalGains(kGains, &gains, &error)) << error;
  structure::Response study;
  ASSERT_TRUE(structure::RunCase(structure::Case::kClippedOptimal, record, ShearFrameParams{},
                                 SpencerParams::Spencer1997(), gains, structure::StudyOptions{},
                                 &study, &error))
      << error;
  const hil::StructureFigures& f = loop.figures;
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(f.peak_x_cm[i], study.peak_x_cm[i], 1e-9) << i;
    EXPECT_NEAR(f.peak_d_cm[i], study.peak_d_cm[i], 1e-9) << i;
    EXPECT_NEAR(f.peak_xa_cm_s2[i], study.peak_xa_cm_s2[i], 1e-6) << i;
    EXPECT_NEAR(f.rms_x_cm[i], study.rms_x_cm[i], 1e-9) << i;
  }
  EXPECT_NEAR(f.peak_force_n, study.peak_force_n, 1e-6);
  EXPECT_NEAR(loop.mean_volts, study.mean_voltage, 1e-9);
}

TEST(StructureFirmwareLawTest, TheInverseCommandControlsTheFrameToo) {
  const LoopResult clipped = RunLoop(firmware::ClippedCommand::kClipped);
  const LoopResult inverse = RunLoop(firmware::ClippedCommand::kInverse);
  EXPECT_EQ(inverse.safe_periods, 0U);
  EXPECT_EQ(inverse.force_law_periods, 7236U);
  // It is another command sequence, and still far below passive-off's roof displacement
  // (0.4031 cm, docs/structure.md).
  EXPECT_NE(inverse.mean_volts, clipped.mean_volts);
  EXPECT_LT(inverse.figures.peak_x_cm[2], 0.3);
}

}  // namespace
}  // namespace mrd
