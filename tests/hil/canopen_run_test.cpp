// `mrd-hil run --profile firmware/profiles/canopen-drive.toml` (labels profile, fieldbus, hil):
// the harness plays a CiA 301 drive (NMT, SDO, heartbeats, PDOs) and the firmware runs the
// same profile. force-v1 closes the loop in lockstep like the native protocol (reachable error
// within 0.005) and for 10 s in real time; a drive that refuses a start-up SDO stops the
// firmware before it drives anything, with the entry and the abort code's meaning; a drive
// whose heartbeat stops puts the firmware in the safe state (fault_line) until it is back.
#include <gtest/gtest.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hil/hil_run.hpp"
#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;
using nlohmann::json;

const std::string kBin = MRD_BIN_DIR;
const std::string kSource = MRD_SOURCE_DIR;
const std::string kPaper = MRD_PAPER_DIR;
const std::string kCanopen = kSource + "/firmware/profiles/canopen-drive.toml";

using mrd::test::ForceV1;
using mrd::test::Hil;
using mrd::test::HilResult;

// A force-v1 scenario of `seconds` on the paper's v1 excitation, with extra TOML (faults).
std::string Scenario(const std::string& name, double seconds, const std::string& extra) {
  const std::string path = ::testing::TempDir() + "/" + name + ".toml";
  FILE* f = std::fopen(path.c_str(), "w");
  EXPECT_NE(f, nullptr);
  std::fprintf(
      f,
      "name = \"%s\"\nduration_s = %g\n[excitation]\nkind = \"csv\"\nfile = \"%s/v1.csv\"\n"
      "demand_column = \"f\"\n[control]\nlaw = \"force\"\n[pass]\n"
      "max_invariant_violations = 0\n%s",
      name.c_str(), seconds, kPaper.c_str(), extra.c_str());
  std::fclose(f);
  return path;
}

TEST(CanopenRunTest, CanopenDriveTracksLikeTheNativeProtocolInLockstep) {
  const HilResult native = Hil(ForceV1());
  std::vector<std::string> args = ForceV1();
  args.insert(args.end(), {"--profile", kCanopen});
  const HilResult drive = Hil(args);
  ASSERT_EQ(native.status, 0) << native.err;
  ASSERT_EQ(drive.status, 0) << drive.err;
  EXPECT_EQ(drive.j["invariant_violations"], 0);
  EXPECT_EQ(drive.j["commands"], 20000);
  const double n = native.j["tracking"]["error_reachable"].get<double>();
  const double d = drive.j["tracking"]["error_reachable"].get<double>();
  EXPECT_NEAR(d, n, 0.005) << "native " << n << ", canopen-drive " << d;
  const json& fw = drive.j["firmware"]["summary"];
  EXPECT_EQ(fw["devices"]["can"]["rx_rejected"], 0);
  EXPECT_EQ(drive.j["ports"]["can"]["rejected"], 0);
  EXPECT_EQ(fw["safe_entries"], 0);
  EXPECT_EQ(fw["clock"]["missed_grants"], 0);
  EXPECT_EQ(drive.j["heartbeat_timeouts"], 0);  // the firmware's CANopen heartbeat kept coming
}

// Real time: every frame accepted on both sides and no fault but staleness (a loaded host may
// delay a period past max_age now and then), as the other profiles' real-time test asserts.
TEST(CanopenRunTest, CanopenDriveRunsTenSecondsInRealTime) {
  std::vector<std::string> args = ForceV1();
  args[0] = Scenario("canopen-force-v1-10s", 10.0, "");
  args.insert(args.end(), {"--profile", kCanopen, "--clock", "realtime"});
  const HilResult r = Hil(args);
  ASSERT_EQ(r.status, 0) << r.err << r.j.dump();
  EXPECT_EQ(r.j["clock"], "realtime");
  EXPECT_EQ(r.j["invariant_violations"], 0);
  const json& fw = r.j["firmware"]["summary"];
  EXPECT_EQ(fw["devices"]["can"]["rx_rejected"], 0) << fw.dump();
  EXPECT_EQ(r.j["ports"]["can"]["rejected"], 0);
  for (const auto& [cause, w] : fw["watchdog"].items()) {
    if (cause != "stale_sensor") {
      EXPECT_EQ(w["trips"], 0) << cause;
    }
  }
  EXPECT_GT(r.j["commands"].get<int>(), 9000);
  std::printf("canopen-drive real time: %d commands, %d safe, %d safe entries\n",
              r.j["commands"].get<int>(), r.j["safe_commands"].get<int>(),
              fw["safe_entries"].get<int>());
}

TEST(CanopenRunTest, ARefusedSdoStopsTheFirmwareBeforeItDrivesAnything) {
  std::vector<std::string> args = ForceV1();
  args.insert(args.end(), {"--profile", kCanopen, "--sdo-refuse", "0x6060=0x06090030"});
  const HilResult r = Hil(args);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("the firmware exited during start-up (exit 1)"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("drive refused SDO 'modes of operation: current' 0x6060:00 = -3: abort "
                       "0x06090030 value range of parameter exceeded"),
            std::string::npos)
      << r.err;
  // Another entry, refused by subindex, in real time.
  args = ForceV1();
  args.insert(args.end(), {"--profile", kCanopen, "--clock", "realtime", "--sdo-refuse",
                           "0x1016:1=0x06040043"});
  const HilResult rt = Hil(args);
  EXPECT_EQ(rt.status, 1);
  EXPECT_NE(rt.err.find("drive refused SDO 'heartbeat consumer: node 1, 50 ms' 0x1016:01 = 65586: "
                        "abort 0x06040043 general parameter incompatibility reason"),
            std::string::npos)
      << rt.err;
}

TEST(CanopenRunTest, ALostDriveHeartbeatPutsTheFirmwareInTheSafeStateUntilItIsBack) {
  std::vector<std::string> args = ForceV1();
  args[0] = Scenario("canopen-heartbeat-loss", 3.0,
                     "[[fault]]\nkind = \"drive_heartbeat_loss\"\nat_s = 1.0\nduration_s = 0.5\n");
  args.insert(args.end(), {"--profile", kCanopen});
  args.erase(args.begin() + 3, args.begin() + 5);  // the scenario names its excitation
  const HilResult r = Hil(args);
  ASSERT_EQ(r.status, 0) << r.err << r.j.dump();
  ASSERT_EQ(r.j["faults"].size(), 1U);
  const json& f = r.j["faults"][0];
  EXPECT_EQ(f["kind"], "drive_heartbeat_loss");
  EXPECT_TRUE(f["ok"].get<bool>()) << f.dump();
  // Detected (the firmware's status shows a cause) within the drive heartbeat timeout of
  // 50 ms after the last heartbeat, safe at once, driving again after it came back.
  EXPECT_LE(f["periods_to_detection"].get<int>(), 51);
  EXPECT_EQ(f["detection_to_safe_periods"], 0);
  EXPECT_TRUE(f["periods_to_recovery"].is_number());
  const json& fw = r.j["firmware"]["summary"];
  EXPECT_EQ(fw["watchdog"]["fault_line"]["trips"], 1);
  EXPECT_EQ(fw["safe_entries"], 1);
  // Without a CANopen profile the fault is refused before anything starts.
  args.erase(args.end() - 2, args.end());
  const HilResult plain = Hil(args);
  EXPECT_EQ(plain.status, 2);
  EXPECT_NE(plain.err.find("needs a CANopen device profile"), std::string::npos) << plain.err;
}

}  // namespace
