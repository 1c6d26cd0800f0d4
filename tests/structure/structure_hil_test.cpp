// The structure in the harness (labels hil, control): [plant] model = "structure" scenarios
// and their refusals, the structure plant against the in-process study, the firmware
// configuration the harness generates for the clipped-optimal law, and the shipped scenario
// run through mrd-hil and mrd-firmware over the local CAN bus (lockstep), close to the study's
// clipped-optimal row and deterministic.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "hil/hil_run.hpp"
#include "mrd/firmware/platform/clipped_optimal_file.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/hil/plants/structure_plant.hpp"
#include "mrd/hil/plants/structure_scores.hpp"
#include "mrd/hil/run/run.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/structure/study.hpp"

namespace mrd::hil {
namespace {

const std::string kScenario =
    std::string(MRD_SOURCE_DIR) + "/hil/scenarios/structure-clipped-optimal.toml";
const std::string kRecord = std::string(MRD_SOURCE_DIR) + "/hil/data/el_centro_1940_ns.csv";
const std::string kGains = std::string(MRD_SOURCE_DIR) + "/hil/data/clipped_optimal_gains.toml";

std::string Write(const std::string& name, const std::string& text) {
  const std::string dir = "/tmp/mrd-structure-hil-" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

const std::string kHead = "name = \"s\"\ndescription = \"d\"\nduration_s = 1.0\n";
std::string PlantAndRecord() {
  return "[plant]\nmodel = \"structure\"\npreset = \"spencer1997\"\n[structure]\nrecord = \"" +
         kRecord + "\"\n";
}

TEST(StructureScenarioTest, TheShippedScenarioLoads) {
  Scenario s;
  std::string error;
  ASSERT_TRUE(LoadScenario(kScenario, &s, &error)) << error;
  EXPECT_TRUE(s.structure);
  EXPECT_FALSE(s.quarter_car);
  ASSERT_NE(s.structure_setup, nullptr);
  EXPECT_EQ(s.structure_setup->record.ag_g.size(), 1560U);
  EXPECT_DOUBLE_EQ(s.structure_setup->record.dt_s, 0.02);
  EXPECT_DOUBLE_EQ(s.structure_setup->time_scale, 5.0);
  EXPECT_EQ(s.law, "clipped-optimal");
  EXPECT_EQ(s.clipped_command, "clipped");
  EXPECT_EQ(s.clipped_gains.front(), '/');  // absolute: the firmware's config is elsewhere
  EXPECT_TRUE(s.peak_drift_below_passive_on);
  EXPECT_TRUE(s.peak_accel_below_passive_on);
  ASSERT_TRUE(s.max_peak_force_n.has_value());
}

TEST(StructureScenarioTest, RefusalsNameTheFileLineAndReason) {
  const std::string uneven = Write("uneven.csv", "t_s,ag_g\n0,0.1\n0.02,0.2\n0.05,0.1\n");
  struct Case {
    std::string text;
    std::string message;
  };
  const Case cases[] = {
      {kHead + "[structure]\nrecord = \"" + kRecord + "\"\n",
       ":4: [structure] needs [plant] model = \"structure\""},
      {kHead + "[plant]\nmodel = \"structure\"\n",
       ":5: model = \"structure\" needs [structure] record"},
      {kHead + "[plant]\nmodel = \"structure\"\n[structure]\nrecord = \"" + uneven + "\"\n",
       ":7: [structure] record: " + uneven + ":4: samples are not equally spaced"},
      {kHead + PlantAndRecord() + "time_scale = 0\n", ":9: 'time_scale' must be a number"},
      {kHead + PlantAndRecord() + "[excitation]\nkind = \"periodic\"\n",
       ":9: a structure is excited by its [structure] record, not [excitation]"},
      {kHead + "[control]\nlaw = \"clipped-optimal\"\ngains = \"" + kGains + "\"\n",
       ":5: law \"clipped-optimal\" needs [plant] model = \"structure\""},
      {kHead + PlantAndRecord() + "[control]\nlaw = \"clipped-optimal\"\n",
       ":10: law \"clipped-optimal\" needs [control] gains"},
      {kHead + PlantAndRecord() + "[control]\nlaw = \"clipped-optimal\"\ngains = \"none.toml\"\n",
       ":11: [control] gains"},
      {kHead + PlantAndRecord() + "[control]\nlaw = \"clipped-optimal\"\ngains = \"" + kGains +
           "\"\nclipped_command = \"bang\"\n",
       ":12: clipped_command must be \"clipped\" or \"inverse\""},
      {kHead + PlantAndRecord() + "[control]\nlaw = \"passive-on\"\ngains = \"" + kGains + "\"\n",
       ":11: 'gains' and 'clipped_command' need law = \"clipped-optimal\""},
      {kHead + "[pass]\npeak_drift_below_passive_on = true\n",
       ":5: 'peak_drift_below_passive_on' needs [plant] model = \"structure\""},
      {kHead + "[pass]\nmax_peak_force_n = 10\n",
       ":5: 'max_peak_force_n' needs [plant] model = \"structure\""}};
  int n = 0;
  for (const Case& k : cases) {
    const std::string path = Write("bad" + std::to_string(n++) + ".toml", k.text);
    Scenario s;
    std::string error;
    EXPECT_FALSE(LoadScenario(path, &s, &error)) << k.text;
    EXPECT_NE(error.find(path + k.message), std::string::npos) << k.text << "\n" << error;
  }
}

// The plant's floors equal the in-process study's at a constant voltage (the same arithmetic).
TEST(StructurePlantTest, PassiveOffEqualsTheStudy) {
  Scenario s;
  std::string error;
  ASSERT_TRUE(LoadScenario(kScenario, &s, &error)) << error;
  StructurePlant plant(s.structure_setup, s.damper, 1e-3, s.substeps);
  StructureMetrics m;
  for (int k = 0; k < 7236; ++k) {
    plant.Step(0.0);
    m.Add(*plant.Structure());
  }
  GroundRecord record;
  ASSERT_TRUE(LoadGroundRecord(kRecord, &record, &error)) << error;
  structure::StudyOptions o;
  structure::Response r;
  ASSERT_TRUE(structure::RunCase(structure::Case::kPassiveOff, record, ShearFrameParams{},
                                 SpencerParams::Spencer1997(), {}, o, &r, &error))
      << error;
  const StructureFigures f = m.Figures();
  for (int i = 0; i < 3; ++i) {
    EXPECT_DOUBLE_EQ(f.peak_x_cm[i], r.peak_x_cm[i]) << i;
    EXPECT_DOUBLE_EQ(f.peak_d_cm[i], r.peak_d_cm[i]) << i;
    EXPECT_DOUBLE_EQ(f.peak_xa_cm_s2[i], r.peak_xa_cm_s2[i]) << i;
    EXPECT_NEAR(f.rms_x_cm[i], r.rms_x_cm[i], 1e-12) << i;
  }
  EXPECT_DOUBLE_EQ(f.peak_force_n, r.peak_force_n);
  // The sample the buses carry: the damper's stroke and the floor accelerations.
  const PlantSample p = plant.Sample();
  EXPECT_TRUE(p.has_structure);
  EXPECT_FALSE(p.has_chassis);
  EXPECT_DOUBLE_EQ(p.x, 100.0 * plant.Structure()->x[0]);
  EXPECT_DOUBLE_EQ(p.floor_acceleration[2], plant.Structure()->xa[2]);
  // A probe does not advance the plant.
  const PlantSample before = plant.Sample();
  (void)plant.Probe(2.25);
  EXPECT_DOUBLE_EQ(plant.Sample().x, before.x);
}

TEST(StructureScenarioTest, TheGeneratedFirmwareConfigRoutesTheFloorAccelerations) {
  Scenario s;
  std::string error;
  ASSERT_TRUE(LoadScenario(kScenario, &s, &error)) << error;
  for (const char* command : {"clipped", "inverse"}) {
    s.clipped_command = command;
    const std::string text = FirmwareConfigText(s, "can", true, "/tmp/bus.sock");
    firmware::platform::FirmwareConfig cfg;
    ASSERT_TRUE(firmware::platform::ParseConfig(text, "gen.toml", &cfg, &error)) << error << "\n"
                                                                                 << text;
    EXPECT_EQ(cfg.controller.law.mode, firmware::ControlMode::kClippedOptimal);
    EXPECT_EQ(cfg.controller.law.clipped_command, std::string(command) == "inverse"
                                                      ? firmware::ClippedCommand::kInverse
                                                      : firmware::ClippedCommand::kClipped);
    EXPECT_TRUE(cfg.controller.clipped_gains_loaded);
    for (const auto in :
         {firmware::Input::kFloorAcceleration1, firmware::Input::kFloorAcceleration2,
          firmware::Input::kFloorAcceleration3, firmware::Input::kForce}) {
      EXPECT_NE(cfg.io.can.inputs & firmware::Bit(in), 0U) << firmware::InputName(in);
    }
  }
}

// The shipped scenario through mrd-hil and mrd-firmware: passes; its passive twins are the
// study's passive-off exactly; the controlled run is within 2 % of the study's
// clipped-optimal row (the difference: the CAN signals' resolution, 0.001 m/s^2 and 0.5 N);
// two runs give the same figures.
TEST(StructureRunTest, TheShippedScenarioPassesCloseToTheStudy) {
  const test::HilResult a = test::Hil({kScenario});
  ASSERT_EQ(a.status, 0) << a.err;
  ASSERT_TRUE(a.j.contains("structure")) << a.j.dump();
  EXPECT_TRUE(a.j.value("pass", false));
  EXPECT_EQ(a.j["steps"], 7236);
  GroundRecord record;
  std::string error;
  ASSERT_TRUE(LoadGroundRecord(kRecord, &record, &error)) << error;
  firmware::ClippedOptimalGains gains;
  ASSERT_TRUE(firmware::platform::LoadClippedOptimalGains(kGains, &gains, &error)) << error;
  structure::StudyOptions o;
  structure::Response clipped, off;
  ASSERT_TRUE(structure::RunCase(structure::Case::kClippedOptimal, record, ShearFrameParams{},
                                 SpencerParams::Spencer1997(), gains, o, &clipped, &error));
  ASSERT_TRUE(structure::RunCase(structure::Case::kPassiveOff, record, ShearFrameParams{},
                                 SpencerParams::Spencer1997(), gains, o, &off, &error));
  const auto& c = a.j["structure"]["controlled"];
  const auto& p = a.j["structure"]["passive_off"];
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(c["peak_x_cm"][i].get<double>(), clipped.peak_x_cm[i], 0.02 * clipped.peak_x_cm[i]);
    EXPECT_NEAR(c["peak_drift_cm"][i].get<double>(), clipped.peak_d_cm[i],
                0.02 * clipped.peak_d_cm[i]);
    EXPECT_NEAR(c["peak_accel_cm_s2"][i].get<double>(), clipped.peak_xa_cm_s2[i],
                0.02 * clipped.peak_xa_cm_s2[i]);
    EXPECT_NEAR(c["rms_x_cm"][i].get<double>(), clipped.rms_x_cm[i], 0.02 * clipped.rms_x_cm[i]);
    EXPECT_DOUBLE_EQ(p["peak_x_cm"][i].get<double>(), off.peak_x_cm[i]);
  }
  EXPECT_NEAR(c["peak_force_n"].get<double>(), clipped.peak_force_n, 0.02 * clipped.peak_force_n);
  // Better than passive-off in every floor displacement, and the thresholds hold.
  for (int i = 0; i < 3; ++i) EXPECT_LT(c["peak_x_cm"][i].get<double>(), off.peak_x_cm[i]);
  const test::HilResult b = test::Hil({kScenario});
  ASSERT_EQ(b.status, 0) << b.err;
  EXPECT_EQ(a.j["structure"], b.j["structure"]);  // deterministic
}

// A threshold it cannot meet fails the run (exit 1) and names the figure.
TEST(StructureRunTest, AnUnmetThresholdFailsTheRun) {
  const test::HilResult r = test::Hil({kScenario, "--set", "pass.max_peak_force_n=100"});
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_FALSE(r.j.value("pass", true));
  bool named = false;
  for (const auto& f : r.j.value("failures", nlohmann::json::array())) {
    named = named || f.get<std::string>().find("peak damper force") != std::string::npos;
  }
  EXPECT_TRUE(named) << r.j.dump();
  // Passive-off as the law: its drift is above passive-on's.
  const test::HilResult off = test::Hil(
      {kScenario, "--set", "control.law=passive-off", "--set", "pass.max_peak_force_n=1e6"});
  EXPECT_EQ(off.status, 2) << off.err;  // gains given for another law: refused
}

}  // namespace
}  // namespace mrd::hil
