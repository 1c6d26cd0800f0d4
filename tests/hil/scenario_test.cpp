// Issue 10: scenario files (TOML, FILE:LINE errors), CSV traces, and the firmware
// configuration mrd-hil run generates (accepted by the firmware's own parser).
#include "mrd/hil/scenario/scenario.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "mrd/firmware/platform/config.hpp"
#include "mrd/hil/plants/plant.hpp"
#include "mrd/hil/run/run.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"

namespace mrd::hil {
namespace {

std::string Write(const std::string& name, const std::string& text) {
  const std::string dir = "/tmp/mrd-hil-scn-" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(ScenarioTest, EveryShippedScenarioLoads) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(MRD_SOURCE_DIR "/hil/scenarios")) {
    if (e.path().extension() != ".toml") continue;
    Scenario s;
    std::string error;
    EXPECT_TRUE(LoadScenario(e.path().string(), &s, &error)) << error;
    EXPECT_FALSE(s.description.empty()) << e.path();
    ++n;
  }
  EXPECT_GE(n, 8);
}

TEST(ScenarioTest, ReadsKeysAndFaults) {
  const auto path = Write("ok.toml",
                          "name = \"x\"\nduration_s = 2.5\n[control]\nlaw = \"passive-on\"\n"
                          "[pass]\nmax_error_reachable = 0.05\n"
                          "[[fault]]\nkind = \"delay\"\nat_s = 1.0\nduration_s = 0.1\n"
                          "delay_periods = 7\n");
  Scenario s;
  std::string error;
  ASSERT_TRUE(LoadScenario(path, &s, &error)) << error;
  EXPECT_DOUBLE_EQ(s.duration_s, 2.5);
  EXPECT_EQ(s.law, "passive-on");
  ASSERT_TRUE(s.max_error_reachable.has_value());
  EXPECT_DOUBLE_EQ(*s.max_error_reachable, 0.05);
  ASSERT_EQ(s.faults.size(), 1U);
  EXPECT_EQ(s.faults[0].kind, FaultKind::kDelay);
  EXPECT_EQ(s.faults[0].delay_periods, 7);
  EXPECT_EQ(s.faults[0].line, 7);
}

TEST(ScenarioTest, ReadsAQuarterCarOnARoad) {
  const auto path = Write("qc.toml",
                          "duration_s = 10\n[plant]\nmodel = \"quarter-car\"\n"
                          "[quarter_car]\nspeed_m_s = 15\nmotion_ratio = 0.8\nsettle_s = 1.5\n"
                          "sprung_mass_kg = 350\n[road]\nclass = \"d\"\nseed = 7\n"
                          "[control]\nlaw = \"skyhook\"\nskyhook_gain = 40\n"
                          "[pass]\nbody_accel_below_passive = true\n");
  Scenario s;
  std::string error;
  ASSERT_TRUE(LoadScenario(path, &s, &error)) << error;
  EXPECT_TRUE(s.quarter_car);
  EXPECT_DOUBLE_EQ(s.car.speed_m_s, 15.0);
  EXPECT_DOUBLE_EQ(s.car.motion_ratio, 0.8);
  EXPECT_DOUBLE_EQ(s.car.sprung_mass_kg, 350.0);
  EXPECT_DOUBLE_EQ(s.car.max_volts, s.e_max);
  EXPECT_DOUBLE_EQ(s.ride_settle_s, 1.5);
  EXPECT_EQ(s.road.road_class, RoadClass::kD);
  EXPECT_EQ(s.road.seed, 7U);
  EXPECT_TRUE(s.body_accel_below_passive);
  EXPECT_DOUBLE_EQ(s.skyhook_gain, 40.0);
}

TEST(ScenarioTest, BadInputNamesFileAndLine) {
  struct Case {
    const char* text;
    const char* line_and_reason;
  } cases[] = {
      {"duration_s = 1\n[control]\nlaww = \"force\"\n", ":3: unknown key 'laww'"},
      {"duration_s = 1\n[contrl]\nlaw = \"force\"\n", ":2: unknown section [contrl]"},
      {"[control]\nlaw = \"pid\"\n", ":2: law must be"},
      {"duration_s = -1\n", ":1: 'duration_s' must be a number"},
      {"[[fault]]\nkind = \"meteor\"\n", ":1: unknown fault kind 'meteor'"},
      {"[[fault]]\nat_s = 1\n", ":1: [[fault]] needs 'kind'"},
      {"duration_s = 1\n[[fault]]\nkind = \"drop\"\nat_s = 2\n", ":2: fault at_s"},
      {"[excitation]\nkind = \"csv\"\n", ":2: kind = \"csv\" needs 'file'"},
      {"[plant]\npreset = \"acme\"\n", ":2: unknown plant preset 'acme'"},
      {"name = \n", ":1: "},
      {"[plant]\nmodel = \"bus\"\n", ":2: plant model must be"},
      {"[road]\nclass = \"C\"\n", ":1: [quarter_car] and [road] need"},
      {"[plant]\nmodel = \"quarter-car\"\n[road]\nclass = \"Z\"\n", ":4: road class must be"},
      {"[plant]\nmodel = \"quarter-car\"\n[quarter_car]\nmotion_ratio = 1.5\n",
       ":4: 'motion_ratio' must be"},
      {"[plant]\nmodel = \"quarter-car\"\n[road]\nn_min = 3.0\n", ":3: [road]: "},
      {"[plant]\nmodel = \"quarter-car\"\n[excitation]\namplitude_cm = 1\n",
       ":3: a quarter car is excited by its [road]"},
      {"duration_s = 1\n[plant]\nmodel = \"quarter-car\"\n[quarter_car]\nsettle_s = 2\n",
       ":5: settle_s must be shorter"},
      {"[pass]\nbody_accel_below_passive = true\n", ":2: body_accel_below_passive needs"},
      {"[pass]\ntyre_load_below_passive_off = true\n", ":2: tyre_load_below_passive_off needs"},
      {"[control]\nlaw = \"groundhook\"\n", ":2: law \"groundhook\" needs [plant] model"},
      {"[control]\nlaw = \"sh-add\"\n", ":2: law \"sh-add\" needs [plant] model"},
      {"[plant]\nmodel = \"quarter-car\"\n[control]\nlaw = \"hybrid\"\nhybrid_alpha = 1.5\n",
       ":5: 'hybrid_alpha' must be"},
      {"[plant]\nmodel = \"quarter-car\"\n[control]\nlaw = \"sh-add\"\nsh_add_alpha = 0\n",
       ":5: 'sh_add_alpha' must be"},
  };
  for (const Case& c : cases) {
    const auto path = Write("bad.toml", c.text);
    Scenario s;
    std::string error;
    EXPECT_FALSE(LoadScenario(path, &s, &error)) << c.text;
    EXPECT_NE(error.find(path + c.line_and_reason), std::string::npos) << c.text << " -> " << error;
  }
}

// model = "full-car": the documented defaults, the keys read, and each refusal at its line.
TEST(ScenarioTest, FullCarReadsItsKeysAndRefusesBadOnes) {
  Scenario s;
  std::string error;
  ASSERT_TRUE(LoadScenario(Write("fc.toml",
                                 "duration_s = 10\n[plant]\nmodel = \"full-car\"\n[full_car]\n"
                                 "coherence = 0.8\ncg_to_front_m = 1.1\npair_step_v = 0.5\n"
                                 "[road]\nclass = \"D\"\n"),
                           &s, &error))
      << error;
  EXPECT_TRUE(s.full_car);
  EXPECT_FALSE(s.quarter_car);
  EXPECT_EQ(s.road_coherence, 0.8);
  EXPECT_EQ(s.full.cg_to_front_m, 1.1);
  EXPECT_EQ(s.full.cg_to_rear_m, FullCarParams{}.cg_to_rear_m);
  EXPECT_EQ(s.pair_step_v, 0.5);
  EXPECT_EQ(s.road.road_class, RoadClass::kD);
  const char* fc = "[plant]\nmodel = \"full-car\"\n";
  struct Case {
    std::string text;
    const char* line_and_reason;
  } cases[] = {
      {"[full_car]\nspeed_m_s = 20\n", ":1: [full_car] needs [plant] model = \"full-car\""},
      {std::string(fc) + "[full_car]\ncoherence = 1.5\n", ":4: 'coherence' must be"},
      {std::string(fc) + "[full_car]\ntrack_rear_m = 0\n", ":4: 'track_rear_m' must be"},
      {std::string(fc) + "[road]\nclass = \"Z\"\n", ":4: road class must be"},
      {std::string(fc) + "[excitation]\namplitude_cm = 1\n",
       ":3: a full car is excited by its [road]"},
      {std::string(fc) + "[full_car]\npair_step_v = 0.01\n",
       ":4: pair_step_v must be > 0 and give at most 100"},
      {"duration_s = 1\n" + std::string(fc) + "[full_car]\nsettle_s = 2\n",
       ":5: settle_s must be shorter"},
      {std::string(fc) + "[quarter_car]\nspeed_m_s = 20\n", ":3: [quarter_car] and [road] need"},
  };
  for (const Case& c : cases) {
    const auto path = Write("bad.toml", c.text);
    EXPECT_FALSE(LoadScenario(path, &s, &error)) << c.text;
    EXPECT_NE(error.find(path + c.line_and_reason), std::string::npos) << c.text << " -> " << error;
  }
}

// [channels]: the shipped four-corner scenario, and each refusal naming its file.
TEST(ScenarioTest, ChannelsReadFourCornersAndRefuseBadOnes) {
  Scenario s;
  std::string error;
  ASSERT_TRUE(LoadScenario(MRD_SOURCE_DIR "/hil/scenarios/full-car-can-corners.toml", &s, &error))
      << error;
  ASSERT_TRUE(s.full_car);
  ASSERT_EQ(s.channels.can_profiles.size(), 4U);
  const char* corners[4] = {"fl", "fr", "rl", "rr"};
  for (int i = 0; i < 4; ++i) {
    const std::string& p = s.channels.can_profiles[static_cast<std::size_t>(i)];
    EXPECT_EQ(p.front(), '/') << "absolute: " << p;
    EXPECT_NE(p.find(std::string("canopen-corner-") + corners[i] + ".toml"), std::string::npos);
  }
  EXPECT_EQ(s.channels.fault_policy, "all");
  EXPECT_EQ(s.channels.body_law, "modal-skyhook");
  ASSERT_EQ(s.faults.size(), 1U);
  EXPECT_EQ(s.faults[0].corner, 2);

  const std::string prof = MRD_SOURCE_DIR "/firmware/profiles/canopen-corner-";
  const std::string four = "can_profiles = [\"" + prof + "fl.toml\", \"" + prof + "fr.toml\", \"" +
                           prof + "rl.toml\", \"" + prof + "rr.toml\"]\n";
  const std::string maps = MRD_SOURCE_DIR "/firmware/profiles/modbus-corner-";
  const std::string four_maps = "modbus_profiles = [\"" + maps + "fl.toml\", \"" + maps +
                                "fr.toml\", \"" + maps + "rl.toml\", \"" + maps + "rr.toml\"]\n";
  const std::string fc = "[plant]\nmodel = \"full-car\"\n";
  const std::string skyhook = "[control]\nlaw = \"skyhook\"\n";
  struct Case {
    std::string text;
    const char* reason;
  } cases[] = {
      {"[channels]\n" + four, "[channels] needs [plant] model = \"full-car\""},
      {fc + skyhook + "[channels]\ncan_profiles = [\"" + prof + "fl.toml\"]\n",
       "can_profiles must name 4"},
      {fc + skyhook + "[channels]\ncan_profiles = [\"a\", \"b\", \"c\", \"d\"]\n", "not a file"},
      {fc + skyhook + "[channels]\n" + four + "fault_policy = \"some\"\n",
       "fault_policy must be \"all\" or \"channel\""},
      {fc + skyhook + "[channels]\n" + four + "body_law = \"x\"\n",
       "body_law must be \"none\" or \"modal-skyhook\""},
      {fc + skyhook + "[channels]\n" + four + "body_law = \"modal-skyhook\"\n",
       "needs [control] law = \"force\""},
      {fc + "[channels]\n" + four, "four corners run law skyhook"},
      {fc + skyhook + "[channels]\n" + four + "heave_n_s_per_m = 1\n",
       "gains need body_law = \"modal-skyhook\""},
      {fc + skyhook + "[channels]\n" + four + "[[fault]]\nkind = \"kill_firmware\"\nat_s = 1\n",
       "fault kind 'kill_firmware' is not played on four corners"},
      {fc + skyhook + "[channels]\n" + four + "[[fault]]\nkind = \"drop\"\ncorner = 4\n",
       "'corner' must be an integer in [0, 3]"},
      {fc + "[[fault]]\nkind = \"drop\"\nat_s = 1\n",
       "takes faults only over CAN or Modbus with [channels]"},
      // The profile's kind is the list's (the transport's), one list at most, and CAN's own
      // faults not on Modbus maps.
      {fc + skyhook + "[channels]\ncan_profiles = [\"" + maps + "fl.toml\", \"" + maps +
           "fr.toml\", \"" + maps + "rl.toml\", \"" + maps + "rr.toml\"]\n",
       "a Modbus device profile; Modbus maps go in modbus_profiles"},
      {fc + skyhook + "[channels]\nmodbus_profiles = [\"" + prof + "fl.toml\", \"" + prof +
           "fr.toml\", \"" + prof + "rl.toml\", \"" + prof + "rr.toml\"]\n",
       "not a Modbus device profile (no [modbus] section)"},
      {fc + skyhook + "[channels]\n" + four + four_maps,
       "[channels] takes can_profiles (four corners over CAN) or modbus_profiles"},
      {fc + skyhook + "[channels]\nmodbus_profiles = [\"" + maps + "fl.toml\"]\n",
       "modbus_profiles must name 4 Modbus register maps"},
      {fc + skyhook + "[channels]\n" + four_maps + "[[fault]]\nkind = \"corrupt\"\nat_s = 1\n",
       "fault kind 'corrupt' is played on CAN only"},
      {"[[fault]]\nkind = \"drop\"\ncorner = 1\nat_s = 1\n", "a fault's 'corner' needs [channels]"},
  };
  for (const Case& c : cases) {
    const auto path = Write("bad.toml", c.text);
    EXPECT_FALSE(LoadScenario(path, &s, &error)) << c.text;
    EXPECT_EQ(error.rfind(path + ":", 0), 0U) << c.text << " -> " << error;
    EXPECT_NE(error.find(c.reason), std::string::npos) << c.text << " -> " << error;
  }
}

TEST(TraceTest, ReadsAGeneratedDataSetAndRefusesBadRows) {
  Trace t;
  std::string error;
  ASSERT_TRUE(
      LoadTrace(Write("ok.csv", "t,x,v,E,f\n0,0,1,0,5\n0.001,0.1,2,0,6\n"), "f", &t, &error))
      << error;
  ASSERT_EQ(t.x.size(), 2U);
  EXPECT_DOUBLE_EQ(t.v[1], 2.0);
  EXPECT_DOUBLE_EQ(t.demand[1], 6.0);
  const auto bad = Write("bad.csv", "t,x,v,E,f\n0,0,1,0,5\n0.001,0.1,nan,0,6\n");
  EXPECT_FALSE(LoadTrace(bad, "f", &t, &error));
  EXPECT_NE(error.find(bad + ":3:"), std::string::npos) << error;
  EXPECT_FALSE(LoadTrace(Write("nov.csv", "t,x,E\n0,0,0\n1,1,1\n"), "", &t, &error));
  EXPECT_NE(error.find(":1: header needs columns 'x' and 'v'"), std::string::npos) << error;
  EXPECT_FALSE(LoadTrace(Write("nod.csv", "x,v\n0,0\n1,1\n"), "demand", &t, &error));
  EXPECT_NE(error.find("no column 'demand'"), std::string::npos) << error;
}

TEST(TracePlantTest, ProbeDoesNotAdvanceAndMatchesStep) {
  Trace t;
  for (int k = 0; k < 100; ++k) {
    t.x.push_back(std::sin(0.05 * static_cast<double>(k)));
    t.v.push_back(50.0 * std::cos(0.05 * static_cast<double>(k)));
    t.demand.push_back(0.0);
  }
  TracePlant p(SpencerParams::Paper(), t, 1e-3, 10);
  for (int k = 0; k < 20; ++k) p.Step(1.0);
  const PlantSample a = p.Probe(2.25), b = p.Probe(0.0);
  EXPECT_GT(std::abs(a.force - b.force), 1.0);  // the voltage matters
  const PlantSample s = p.Step(2.25);
  EXPECT_DOUBLE_EQ(s.force, a.force);
  EXPECT_DOUBLE_EQ(s.t_s, a.t_s);
}

// The quarter car seen as a harness plant: Probe predicts Step without advancing, and the ride
// outputs are the plant's.
TEST(QuarterCarAdapterTest, ProbeDoesNotAdvanceAndMatchesStep) {
  QuarterCarAdapter p(SpencerParams::Paper(), QuarterCarParams{}, RoadParams{}, 1e-3);
  for (int k = 0; k < 500; ++k) p.Step(1.0);
  const PlantSample before = p.Sample();
  const PlantSample a = p.Probe(2.25), b = p.Probe(0.0);
  EXPECT_DOUBLE_EQ(p.Sample().t_s, before.t_s);
  EXPECT_DOUBLE_EQ(p.Sample().force, before.force);
  EXPECT_GT(std::abs(a.force - b.force), 1.0);
  const PlantSample s = p.Step(2.25);
  EXPECT_DOUBLE_EQ(s.force, a.force);
  EXPECT_DOUBLE_EQ(s.body_velocity, a.body_velocity);
  ASSERT_NE(p.Ride(), nullptr);
  EXPECT_DOUBLE_EQ(p.Ride()->plant.force, s.force);
  EXPECT_NE(p.Ride()->body_accel, 0.0);
  TracePlant t(SpencerParams::Paper(), Trace{}, 1e-3, 1);
  EXPECT_EQ(t.Ride(), nullptr);
}

// The generated configuration is accepted by the firmware's own parser, per transport/clock.
TEST(FirmwareConfigTest, GeneratedConfigsParse) {
  Scenario s;
  s.path = "x.toml";
  struct Case {
    const char* transport;
    bool lockstep;
    const char* endpoint;
  } cases[] = {{"can", true, "/tmp/bus.sock"},
               {"can", false, "/tmp/bus.sock"},
               {"modbus-tcp", false, "127.0.0.1:1502"},
               {"modbus-rtu", false, "/tmp/pty"}};
  for (const std::string law : {"force", "passive-off", "passive-on", "skyhook"}) {
    s.law = law;
    for (const Case& c : cases) {
      const std::string text = FirmwareConfigText(s, c.transport, c.lockstep, c.endpoint);
      firmware::platform::FirmwareConfig cfg;
      std::string error;
      ASSERT_TRUE(firmware::platform::ParseConfig(text, "gen.toml", &cfg, &error)) << error << "\n"
                                                                                   << text;
      EXPECT_EQ(cfg.clock == firmware::platform::LoopClock::kGrant, c.lockstep);
      EXPECT_EQ(cfg.io.can.lockstep, c.lockstep);
      EXPECT_EQ(cfg.io.can.enabled, std::string(c.transport) == "can");
      EXPECT_EQ(cfg.io.modbus.enabled, std::string(c.transport) != "can");
    }
  }
}

// A four-corner run's configuration: four channels on one lockstep [can] bus, each with its
// corner's profile, the policy and the modal skyhook on the car's geometry; per-corner
// skyhook without a body law.
TEST(FirmwareConfigTest, CornersConfigGivesFourChannelsOnOneBus) {
  Scenario s;
  std::string error;
  ASSERT_TRUE(LoadScenario(MRD_SOURCE_DIR "/hil/scenarios/full-car-can-corners.toml", &s, &error))
      << error;
  profile::CanProfile first;
  ASSERT_TRUE(profile::LoadCanProfile(s.channels.can_profiles[0], &first, &error)) << error;
  for (const bool modal : {true, false}) {
    if (!modal) {
      s.channels.body_law = "none";
      s.channels.fault_policy = "channel";
      s.law = "skyhook";
    }
    const std::string text = CornersConfigText(s, "/tmp/bus.sock", first);
    firmware::platform::FirmwareConfig cfg;
    ASSERT_TRUE(firmware::platform::ParseConfig(text, "gen.toml", &cfg, &error)) << error << "\n"
                                                                                 << text;
    EXPECT_EQ(cfg.clock, firmware::platform::LoopClock::kGrant);
    EXPECT_TRUE(cfg.io.can.enabled);
    EXPECT_TRUE(cfg.io.can.lockstep);
    const firmware::platform::ChannelsConfig& ch = cfg.channels;
    EXPECT_EQ(ch.count, 4);
    EXPECT_EQ(ch.can_profiles, s.channels.can_profiles);
    EXPECT_EQ(ch.fault_policy,
              modal ? firmware::FaultPolicy::kAll : firmware::FaultPolicy::kChannel);
    EXPECT_EQ(ch.body_law, modal ? firmware::platform::BodyLawKind::kModalSkyhook
                                 : firmware::platform::BodyLawKind::kNone);
    if (modal) {
      EXPECT_EQ(ch.geometry.cg_to_front_m, s.full.cg_to_front_m);
      EXPECT_EQ(ch.geometry.cg_to_rear_m, s.full.cg_to_rear_m);
      EXPECT_EQ(ch.geometry.motion_ratio, s.full.motion_ratio);
    }
  }
}

// The Modbus four-corner scenario and its configuration: four channels on one lockstep
// [modbus] link (TCP or RTU), each with its corner's map, the [modbus] section naming none.
TEST(FirmwareConfigTest, CornersModbusConfigGivesFourChannelsOnOneLink) {
  Scenario s;
  std::string error;
  ASSERT_TRUE(
      LoadScenario(MRD_SOURCE_DIR "/hil/scenarios/full-car-modbus-corners.toml", &s, &error))
      << error;
  ASSERT_TRUE(s.channels.modbus());
  ASSERT_EQ(s.channels.modbus_profiles.size(), 4U);
  EXPECT_TRUE(s.channels.can_profiles.empty());
  EXPECT_NE(s.channels.modbus_profiles[3].find("modbus-corner-rr.toml"), std::string::npos);
  profile::ModbusProfile first;
  ASSERT_TRUE(profile::LoadModbusProfile(s.channels.modbus_profiles[0], &first, &error)) << error;
  for (const char* transport : {"modbus-tcp", "modbus-rtu"}) {
    const bool tcp = std::string(transport) == "modbus-tcp";
    const std::string text =
        CornersModbusConfigText(s, transport, tcp ? "127.0.0.1:1502" : "/tmp/pty", first);
    firmware::platform::FirmwareConfig cfg;
    ASSERT_TRUE(firmware::platform::ParseConfig(text, "gen.toml", &cfg, &error)) << error << "\n"
                                                                                 << text;
    EXPECT_EQ(cfg.clock, firmware::platform::LoopClock::kGrant);
    EXPECT_FALSE(cfg.io.can.enabled);
    EXPECT_TRUE(cfg.io.modbus.enabled);
    EXPECT_TRUE(cfg.io.modbus.lockstep);
    EXPECT_EQ(cfg.io.modbus.mode, tcp ? firmware::ModbusMode::kTcp : firmware::ModbusMode::kRtu);
    EXPECT_TRUE(cfg.io.modbus.profile.empty());
    EXPECT_EQ(cfg.channels.count, 4);
    EXPECT_EQ(cfg.channels.modbus_profiles, s.channels.modbus_profiles);
    EXPECT_EQ(cfg.channels.modbus_device_profiles.size(), 4U);
    EXPECT_EQ(cfg.channels.body_law, firmware::platform::BodyLawKind::kModalSkyhook);
  }
}

TEST(FirmwareConfigTest, GrantClockNeedsABusThatCarriesGrants) {
  firmware::platform::FirmwareConfig cfg;
  std::string error;
  EXPECT_FALSE(
      firmware::platform::ParseConfig("[loop]\nclock = \"grant\"\n", "g.toml", &cfg, &error));
  EXPECT_NE(error.find("g.toml:2: clock = \"grant\" needs a [can] or [modbus] section"),
            std::string::npos)
      << error;
}

}  // namespace
}  // namespace mrd::hil
