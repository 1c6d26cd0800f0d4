// Issue 10: `mrd-hil run` against a real mrd-firmware process, per transport and clock, with
// the paper run's table (CTest fixture hil_paper_table: mrd generate -> identify -> export).
// Every test checks the figures in the JSON summary, not only the exit status.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;
using nlohmann::json;

const std::string kBin = MRD_BIN_DIR;
const std::string kScn = std::string(MRD_SOURCE_DIR) + "/hil/scenarios/";
const std::string kPaper = MRD_PAPER_DIR;

struct HilResult {
  int status = -1;
  json j;
  std::string out, err;
};

HilResult Hil(std::vector<std::string> args, double timeout_s = 90.0) {
  args.insert(args.begin(), {kBin + "/mrd-hil", "run"});
  args.push_back("--json");
  ChildProcess p(args);
  HilResult r;
  r.status = p.Wait(timeout_s);
  r.out = p.Stdout();
  r.err = p.Stderr();
  r.j = json::parse(r.out, nullptr, false);
  if (r.j.is_discarded()) r.j = json::object();
  return r;
}

std::string Table() { return kPaper + "/table.bin"; }

// Force tracking with the paper table, lockstep over the local CAN bus.
void ExpectTracking(const HilResult& r, double limit) {
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["clock"], "lockstep");
  EXPECT_EQ(r.j["transport"], "can");
  EXPECT_EQ(r.j["invariant_violations"], 0);
  EXPECT_EQ(r.j["command_timeouts"], 0);
  const json& t = r.j["tracking"];
  EXPECT_LE(t["error_reachable"].get<double>(), limit);
  EXPECT_GT(t["reachable_steps"].get<int>(), 1000);
  // Far better than either passive setting on the same excitation.
  EXPECT_LT(t["error_reachable"].get<double>(),
            0.2 * t["passive_off"]["error_reachable"].get<double>());
  EXPECT_EQ(r.j["firmware"]["summary"]["clock"]["missed_grants"], 0);
  EXPECT_EQ(r.j["firmware"]["exit"], 0);
}

TEST(HilRunTest, ForceTrackingPeriodicLockstepCan) {
  ExpectTracking(Hil({kScn + "force-periodic.toml", "--table", Table()}), 0.05);
}

TEST(HilRunTest, ForceTrackingV1LockstepCan) {
  ExpectTracking(
      Hil({kScn + "force-v1.toml", "--table", Table(), "--excitation", kPaper + "/v1.csv"}), 0.05);
}
TEST(HilRunTest, ForceTrackingV2LockstepCan) {
  ExpectTracking(
      Hil({kScn + "force-v2.toml", "--table", Table(), "--excitation", kPaper + "/v2.csv"}), 0.05);
}
TEST(HilRunTest, ForceTrackingV3LockstepCan) {
  ExpectTracking(
      Hil({kScn + "force-v3.toml", "--table", Table(), "--excitation", kPaper + "/v3.csv"}), 0.05);
}

// Quarter car on an ISO 8608 class C road at 20 m/s: skyhook through the inverse of the paper
// run's NARX model (mrd export) lowers the body-acceleration RMS below both passive cases on the
// same car and road, lockstep over the local CAN bus.
TEST(HilRunTest, QuarterCarSkyhookBeatsBothPassiveCasesLockstepCan) {
  const HilResult r = Hil({kScn + "quarter-car-skyhook.toml", "--table", Table()});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(r.j["pass"].get<bool>());
  EXPECT_EQ(r.j["invariant_violations"], 0);
  EXPECT_EQ(r.j["command_timeouts"], 0);
  // Safe only while the firmware starts (its first periods, before fresh sensors).
  EXPECT_LE(r.j["safe_commands"].get<int>(), 5);
  EXPECT_EQ(r.j["firmware"]["summary"]["clock"]["missed_grants"], 0);
  const json& ride = r.j["ride"];
  const double sky = ride["controlled"]["body_accel_rms"].get<double>();
  const double off = ride["passive_off"]["body_accel_rms"].get<double>();
  const double on = ride["passive_on"]["body_accel_rms"].get<double>();
  std::printf("body acceleration RMS [m/s^2]: skyhook %.4f, passive-off %.4f, passive-on %.4f\n",
              sky, off, on);
  EXPECT_LT(sky, off);
  EXPECT_LT(sky, on);
  EXPECT_EQ(ride["controlled"]["samples"], 23000);  // 25 s, scored after 2 s
  EXPECT_GT(ride["controlled"]["travel_rms_cm"].get<double>(), 0.0);
  EXPECT_GT(ride["controlled"]["tyre_load_rms_n"].get<double>(), 0.0);
}

// --attach: the harness writes the configuration, prints how to start the firmware and waits
// for one started by hand (here by the test, from that configuration); it never starts or
// stops a firmware itself.
TEST(HilRunTest, AttachesToAFirmwareStartedByHand) {
  const std::string dir = "/tmp/mrd-hil-attach-" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  ChildProcess hil({kBin + "/mrd-hil", "run", kScn + "closed-loop-smoke.toml", "--attach", "--out",
                    dir, "--json"});
  const std::string config = dir + "/firmware.toml";
  // The prompt comes once the configuration is written.
  for (int i = 0; i < 200 && hil.Stderr().find("started by hand") == std::string::npos; ++i) {
    usleep(50'000);
  }
  ASSERT_TRUE(std::filesystem::exists(config)) << hil.Stderr();
  ChildProcess fw({kBin + "/mrd-firmware", "--config", config, "--table", Table(), "--duration",
                   "2", "--json"});
  EXPECT_EQ(fw.Wait(60.0), 0) << fw.Stderr();
  ASSERT_EQ(hil.Wait(60.0), 0) << hil.Stdout() << hil.Stderr();
  EXPECT_NE(hil.Stderr().find("waiting for a firmware started by hand"), std::string::npos);
  const json j = json::parse(hil.Stdout(), nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << hil.Stdout();
  EXPECT_TRUE(j["pass"].get<bool>());
  EXPECT_EQ(j["firmware"]["starts"], 0);  // none of its own
  EXPECT_EQ(j["firmware"]["exit"], -1);
  EXPECT_EQ(j["invariant_violations"], 0);
  EXPECT_EQ(j["command_timeouts"], 0);
  EXPECT_EQ(j["commands"], 2000);
  // The firmware ran on the harness's grants: one per step.
  const json f = json::parse(fw.Stdout(), nullptr, false);
  ASSERT_FALSE(f.is_discarded()) << fw.Stdout();
  EXPECT_EQ(f["clock"]["missed_grants"], 0) << fw.Stdout();
}

// Two lockstep runs give identical summaries (all but the wall-clock "timing").
TEST(HilRunTest, LockstepIsDeterministic) {
  HilResult a = Hil({kScn + "closed-loop-smoke.toml", "--table", Table()});
  HilResult b = Hil({kScn + "closed-loop-smoke.toml", "--table", Table()});
  ASSERT_EQ(a.status, 0) << a.out << a.err;
  ASSERT_EQ(b.status, 0) << b.out << b.err;
  a.j.erase("timing");
  b.j.erase("timing");
  EXPECT_EQ(a.j.dump(1), b.j.dump(1));
  EXPECT_GT(a.j["commands"].get<int>(), 1900);
}

// Each sensor fault: detected, safe within 2 periods of detection, recovered; invariant held.
TEST(HilRunTest, SensorFaultsDetectedSafeAndRecovered) {
  const HilResult r = Hil({kScn + "faults-sensor.toml", "--table", Table()});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["invariant_violations"], 0);
  ASSERT_EQ(r.j["faults"].size(), 7U);
  for (const json& f : r.j["faults"]) {
    SCOPED_TRACE(f.dump());
    EXPECT_TRUE(f["ok"].get<bool>());
    ASSERT_FALSE(f["periods_to_detection"].is_null());
    EXPECT_LE(f["periods_to_detection"].get<int>(), 6);  // max_age 5 ms
    ASSERT_FALSE(f["periods_to_safe_state"].is_null());
    EXPECT_LE(f["detection_to_safe_periods"].get<int>(), 2);
    EXPECT_GE(f["detection_to_safe_periods"].get<int>(), 0);
    ASSERT_FALSE(f["periods_to_recovery"].is_null());
    EXPECT_LE(f["periods_to_recovery"].get<int>(), 50);
  }
  // Frames refused by the firmware are counted by the reason (corrupt: crc; out of range: bad
  // value; stall: repeated counters).
  const json& errors = r.j["firmware"]["summary"]["devices"]["can"]["errors"];
  EXPECT_GT(errors["crc"].get<int>(), 0);
  EXPECT_GT(errors["bad_value"].get<int>(), 0);
  EXPECT_GT(errors["rejected_frame"].get<int>(), 0);
  // Refused frames are the device's business: no period of the loop's reads or writes of the
  // CAN device faulted (the watchdog's stale and implausible causes did the detecting).
  const json& can = r.j["firmware"]["summary"]["devices"]["can"];
  ASSERT_TRUE(can.contains("faulted_periods") && can.contains("last_period_fault")) << can.dump();
  for (const char* side : {"read", "write"}) {
    ASSERT_EQ(can["faulted_periods"][side].size(), 10U) << can.dump();  // every IoError
    for (const auto& [reason, n] : can["faulted_periods"][side].items()) {
      EXPECT_EQ(n.get<int>(), 0) << side << " " << reason;
    }
    EXPECT_EQ(can["last_period_fault"][side], "none");
  }
}

TEST(HilRunTest, KillPlantSideAndRestart) {
  const HilResult r = Hil({kScn + "fault-kill-plant.toml", "--table", Table()});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["invariant_violations"], 0);
  const json& f = r.j["faults"][0];
  EXPECT_TRUE(f["ok"].get<bool>()) << f.dump();
  ASSERT_FALSE(f["periods_to_recovery"].is_null());
  // Lockstep: the plant's node is silent while the harness keeps granting time; the firmware
  // sees its data go stale within max_age (5 ms) in simulated time and holds the safe state.
  // No grant is missed and none is needed: 1500 steps + the closing tick.
  EXPECT_EQ(r.j["firmware"]["summary"]["clock"]["missed_grants"], 0);
  EXPECT_EQ(r.j["firmware"]["summary"]["clock"]["grants"], 1501);
  EXPECT_GT(r.j["firmware"]["summary"]["watchdog"]["stale_sensor"]["trips"].get<int>(), 0);
  EXPECT_LE(f["periods_to_safe_state"].get<int>(), 6);
}

// kill -9: the simulated driver's own heartbeat timeout drops the coil; a new firmware takes
// over.
TEST(HilRunTest, KillNineOfTheFirmware) {
  const HilResult r = Hil({kScn + "fault-kill-firmware.toml", "--table", Table()});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["invariant_violations"], 0);
  EXPECT_EQ(r.j["firmware"]["starts"], 2);
  const json& f = r.j["faults"][0];
  EXPECT_TRUE(f["ok"].get<bool>()) << f.dump();
  // Heartbeat timeout 50 ms, heartbeat every 10 ms: the coil drops within 40..51 periods.
  EXPECT_GE(f["periods_to_safe_state"].get<int>(), 40);
  EXPECT_LE(f["periods_to_safe_state"].get<int>(), 51);
  EXPECT_GE(r.j["heartbeat_timeouts"].get<int>(), 1);
  ASSERT_FALSE(f["periods_to_recovery"].is_null());
}

TEST(HilRunTest, KillNineOfTheFirmwareOverModbusTcp) {
  const HilResult r = Hil({kScn + "fault-kill-firmware.toml", "--table", Table(), "--transport",
                           "modbus-tcp", "--clock", "realtime"});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["clock"], "realtime");
  EXPECT_EQ(r.j["invariant_violations"], 0);
  EXPECT_EQ(r.j["firmware"]["starts"], 2);
  const json& f = r.j["faults"][0];
  EXPECT_TRUE(f["ok"].get<bool>()) << f.dump();
  EXPECT_LE(f["periods_to_safe_state"].get<int>(), 60);
  ASSERT_FALSE(f["periods_to_recovery"].is_null());
}

TEST(HilRunTest, CorruptTableIsRefused) {
  const HilResult r = Hil({kScn + "fault-corrupt-table.toml", "--table", Table()});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["firmware"]["exit"], 2);
  EXPECT_EQ(r.j["driven_steps"], 0);
}

// Lockstep over Modbus (the grant register): TCP and RTU give the same run, bit for bit, and
// the same tracking as CAN up to the transports' quantisation (CAN carries velocity in 0.01
// cm/s and forces in 1 N steps, the Modbus registers in 1e-4 cm/s and 0.01 N).
TEST(HilRunTest, LockstepOverModbusTcpAndRtuMatchesCan) {
  HilResult can = Hil({kScn + "force-periodic.toml", "--table", Table()});
  HilResult tcp =
      Hil({kScn + "force-periodic.toml", "--table", Table(), "--transport", "modbus-tcp"});
  HilResult rtu =
      Hil({kScn + "force-periodic.toml", "--table", Table(), "--transport", "modbus-rtu"});
  for (const HilResult* r : {&can, &tcp, &rtu}) {
    ASSERT_EQ(r->status, 0) << r->out << r->err;
    EXPECT_EQ(r->j["clock"], "lockstep");
    EXPECT_EQ(r->j["invariant_violations"], 0);
    EXPECT_EQ(r->j["command_timeouts"], 0);
    EXPECT_EQ(r->j["commands"], 3000);
    EXPECT_EQ(r->j["firmware"]["summary"]["clock"]["grants"], 3001);  // + the closing tick
    EXPECT_EQ(r->j["firmware"]["summary"]["clock"]["missed_grants"], 0);
  }
  EXPECT_EQ(tcp.j["tracking"].dump(), rtu.j["tracking"].dump());
  EXPECT_EQ(tcp.j["safe_commands"], rtu.j["safe_commands"]);
  EXPECT_LE(tcp.j["tracking"]["error_reachable"].get<double>(), 0.05);
  EXPECT_NEAR(tcp.j["tracking"]["error_reachable"].get<double>(),
              can.j["tracking"]["error_reachable"].get<double>(), 1e-3);
}

// The register faults over Modbus in lockstep, TCP and RTU: each detected, safe within 2
// periods, recovered; invariant held.
void ExpectRegisterFaults(const HilResult& r) {
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["invariant_violations"], 0);
  ASSERT_EQ(r.j["faults"].size(), 6U);
  for (const json& f : r.j["faults"]) {
    SCOPED_TRACE(f.dump());
    EXPECT_TRUE(f["ok"].get<bool>());
    ASSERT_FALSE(f["periods_to_detection"].is_null());
    EXPECT_LE(f["periods_to_detection"].get<int>(), 6);  // max_age 5 ms
    EXPECT_LE(f["detection_to_safe_periods"].get<int>(), 2);
    EXPECT_FALSE(f["periods_to_recovery"].is_null());
  }
}
TEST(HilRunTest, RegisterFaultsOverModbusTcpLockstep) {
  ExpectRegisterFaults(
      Hil({kScn + "faults-register.toml", "--table", Table(), "--transport", "modbus-tcp"}));
}
TEST(HilRunTest, RegisterFaultsOverModbusRtuLockstep) {
  ExpectRegisterFaults(
      Hil({kScn + "faults-register.toml", "--table", Table(), "--transport", "modbus-rtu"}));
}
TEST(HilRunTest, KillPlantSideOverModbusTcpLockstep) {
  const HilResult r =
      Hil({kScn + "fault-kill-plant.toml", "--table", Table(), "--transport", "modbus-tcp"});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["invariant_violations"], 0);
  const json& f = r.j["faults"][0];
  EXPECT_TRUE(f["ok"].get<bool>()) << f.dump();
  EXPECT_FALSE(f["periods_to_recovery"].is_null());
}

// Real time over each transport: the loop closes, the invariant holds.
void ExpectSmoke(const HilResult& r, const char* transport) {
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.j["transport"], transport);
  EXPECT_EQ(r.j["clock"], "realtime");
  EXPECT_EQ(r.j["invariant_violations"], 0);
  EXPECT_GT(r.j["commands"].get<int>(), 500);
  EXPECT_LT(r.j["tracking"]["error_all"].get<double>(), 0.5);
  EXPECT_GT(r.j["timing"]["wake_jitter_us"]["count"].get<int>(), 1900);
}

TEST(HilRunTest, RealTimeOverLocalCan) {
  ExpectSmoke(Hil({kScn + "closed-loop-smoke.toml", "--table", Table(), "--clock", "realtime"}),
              "can");
}
TEST(HilRunTest, RealTimeOverModbusTcp) {
  ExpectSmoke(Hil({kScn + "closed-loop-smoke.toml", "--table", Table(), "--transport", "modbus-tcp",
                   "--clock", "realtime"}),
              "modbus-tcp");
}
TEST(HilRunTest, RealTimeOverModbusRtuPty) {
  ExpectSmoke(Hil({kScn + "closed-loop-smoke.toml", "--table", Table(), "--transport", "modbus-rtu",
                   "--clock", "realtime"}),
              "modbus-rtu");
}

// Criteria that do not hold: exit 1 with the reason.
TEST(HilRunTest, FailingCriteriaExitOne) {
  const std::string dir = "/tmp/mrd-hil-fail-" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/strict.toml")
      << "name = \"strict\"\ndescription = \"x\"\nduration_s = 0.5\n"
         "[control]\nlaw = \"passive-off\"\n"
         "[pass]\nmax_error_all = 0.05\n";
  const HilResult r = Hil({dir + "/strict.toml", "--table", Table()});
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_FALSE(r.j["pass"].get<bool>());
  ASSERT_EQ(r.j["failures"].size(), 1U);
  EXPECT_NE(r.j["failures"][0].get<std::string>().find("tracking error"), std::string::npos);
}

// A passive-on car cannot beat passive-on: body_accel_below_passive fails with its figures.
TEST(HilRunTest, QuarterCarCriterionFailsForAPassiveCar) {
  const std::string dir = "/tmp/mrd-hil-qcfail-" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/on.toml")
      << "name = \"on\"\ndescription = \"x\"\nduration_s = 3\n"
         "[plant]\nmodel = \"quarter-car\"\n"
         "[quarter_car]\nsettle_s = 1\n[control]\nlaw = \"passive-on\"\n"
         "[pass]\nbody_accel_below_passive = true\n";
  const HilResult r = Hil({dir + "/on.toml"});
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  ASSERT_EQ(r.j["failures"].size(), 1U) << r.out;
  EXPECT_NE(r.j["failures"][0].get<std::string>().find("body acceleration RMS"), std::string::npos);
  // The controlled car at E_max is the passive-on twin, but for its first safe periods while
  // the firmware starts.
  EXPECT_NEAR(r.j["ride"]["controlled"]["body_accel_rms"].get<double>(),
              r.j["ride"]["passive_on"]["body_accel_rms"].get<double>(), 1e-4);
  EXPECT_EQ(r.j["ride"]["controlled"]["samples"], 2000);
}

TEST(HilRunTest, BadInputExitTwo) {
  const std::string dir = "/tmp/mrd-hil-bad-" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/bad.toml") << "duration_s = 1\n[control]\nlaw = \"force\"\nfoo = 1\n";
  HilResult r = Hil({dir + "/bad.toml"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find(dir + "/bad.toml:4: unknown key 'foo'"), std::string::npos) << r.err;
  r = Hil({kScn + "closed-loop-smoke.toml", "--transport", "modbus-tcp", "--clock", "sometimes"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--clock 'sometimes': expected lockstep or realtime"), std::string::npos)
      << r.err;
  r = Hil({kScn + "closed-loop-smoke.toml", "--table", dir + "/missing.bin"});
  EXPECT_EQ(r.status, 2);
  // Corrupt frames are not injected over Modbus: refused, not silently skipped.
  r = Hil({kScn + "faults-sensor.toml", "--transport", "modbus-rtu"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("faults-sensor.toml:32: fault 'corrupt' is injected on CAN frames only"),
            std::string::npos)
      << r.err;
}

}  // namespace
