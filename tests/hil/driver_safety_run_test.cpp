// Every driver's safety features against the harness playing the driver (labels profile,
// fieldbus, conformance, hil): a Modbus driver refusing its enable write still hears the safe
// set-point; a driver's faults count without fault_line routing; a profile whose safe state
// is not the driver's off, or whose [command] range is beyond its set-point signal, is refused
// by both sides, identically on every attempt; a driver without heartbeat supervision and
// with a 10 ms status under a 50 ms timeout closes force-v1 in lockstep.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "hil/hil_run.hpp"
#include "support/process.hpp"

namespace {

using nlohmann::json;

const std::string kBin = MRD_BIN_DIR;
const std::string kSource = MRD_SOURCE_DIR;
const std::string kPaper = MRD_PAPER_DIR;
const std::string kProfiles = kSource + "/firmware/profiles/";
const std::string kTestProfiles = kSource + "/tests/data/profiles/";

using mrd::test::Hil;
using mrd::test::HilResult;

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string Write(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// A force-v1 scenario of `seconds` on the paper's v1 excitation, with extra TOML (faults).
std::string Scenario(const std::string& name, double seconds, const std::string& extra) {
  std::ostringstream s;
  s << "name = \"" << name << "\"\nduration_s = " << seconds << "\n[excitation]\nkind = "
    << "\"csv\"\nfile = \"" << kPaper << "/v1.csv\"\ndemand_column = \"f\"\n[control]\n"
    << "law = \"force\"\n[pass]\nmax_invariant_violations = 0\n"
    << extra;
  return Write(name + ".toml", s.str());
}

// One row of trace.csv: t, ..., command (col 7), applied (8), safe (9), driven (10), causes (12).
struct Row {
  double t = 0, command = 0, applied = 0;
  bool safe = false, driven = false;
  int causes = 0;
};
std::vector<Row> Trace(const std::string& dir) {
  std::ifstream in(dir + "/trace.csv");
  std::string line;
  std::getline(in, line);
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> c;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) c.push_back(cell);
    if (c.size() < 13) continue;
    rows.push_back({std::stod(c[0]), std::stod(c[7]), std::stod(c[8]), c[9] == "1", c[10] == "1",
                    std::stoi(c[12])});
  }
  return rows;
}

// The shipped modbus-float32 profile without its fault_line input (its sensor module has no
// fault line): the driver's faults are the only fault input, and the harness's generated
// configuration cannot route fault_line.
std::string Float32WithoutFaultLine() {
  std::string text = Slurp(kProfiles + "modbus-float32.toml");
  const auto at = text.find("fault_line = {");
  EXPECT_NE(at, std::string::npos);
  text.erase(at, text.find('\n', at) - at + 1);
  return Write("modbus-no-fault-line.toml", text);
}

// A Modbus driver that answers the write of its enable coil with an exception for 1 s: the
// rest of each cycle (the set-point and heartbeat block) must still reach it, carrying the
// safe values, so the coil is off while the firmware says safe.
TEST(DriverSafetyRunTest, AModbusDriverRefusingItsEnableWriteStillHearsTheSafeSetpoint) {
  const std::string out = ::testing::TempDir() + "/enable-refused";
  const HilResult r = Hil({Scenario("enable-refused", 4.0,
                                    "[[fault]]\nkind = \"enable_refused\"\nat_s = 1.5\n"
                                    "duration_s = 1.0\n"),
                           "--table", kPaper + "/table.bin", "--profile",
                           kProfiles + "modbus-float32.toml", "--out", out});
  ASSERT_EQ(r.status, 0) << r.err << r.j.dump();
  ASSERT_EQ(r.j["faults"].size(), 1U);
  const json& f = r.j["faults"][0];
  EXPECT_TRUE(f["ok"].get<bool>()) << f.dump();
  // The refused cycle itself carries the safe values: the driver hears the safe state in the
  // period after the first refusal, before the firmware's status shows the causes.
  EXPECT_LE(f["periods_to_safe_state"].get<int>(), 1) << f.dump();
  EXPECT_LE(f["periods_to_detection"].get<int>(), 3) << f.dump();
  EXPECT_TRUE(f["periods_to_recovery"].is_number()) << f.dump();
  EXPECT_EQ(r.j["commands"], 4000);  // a command block every period, refused enable or not
  // While refused: every step from the first safe one to the fault's end heard the safe
  // set-point (0 V) and the simulated driver applied nothing.
  const std::vector<Row> rows = Trace(out);
  ASSERT_EQ(rows.size(), 4000U);
  int safe_steps = 0, driven_while_safe = 0;
  for (std::size_t k = 1500 + f["periods_to_safe_state"].get<std::size_t>(); k < 2500; ++k) {
    safe_steps += rows[k].safe ? 1 : 0;
    if (rows[k].command != 0.0 || rows[k].applied != 0.0) ++driven_while_safe;
  }
  EXPECT_GT(safe_steps, 990);
  EXPECT_EQ(driven_while_safe, 0);
  const json& fw = r.j["firmware"]["summary"];
  EXPECT_GE(fw["devices"]["modbus"]["errors"]["exception"].get<int>(), 900) << fw.dump();
  // A refused write is the Modbus bus's fault as much as the driver's (both causes).
  EXPECT_EQ(fw["watchdog"]["modbus_bus"]["trips"], 1) << fw.dump();
  EXPECT_EQ(fw["watchdog"]["driver_fault"]["trips"], 1) << fw.dump();
  std::printf(
      "[ figures ] enable refused 1 s: detection %d periods, %d safe steps, "
      "%d exceptions, 0 driven\n",
      f["periods_to_detection"].get<int>(), safe_steps,
      fw["devices"]["modbus"]["errors"]["exception"].get<int>());
}

// A Modbus profile that maps driver_faults but no fault_line: the driver's fault report is the
// fault_line cause although [modbus] inputs cannot list fault_line.
TEST(DriverSafetyRunTest, ADriverFaultCountsWithoutFaultLineRouting) {
  const std::string out = ::testing::TempDir() + "/driver-fault";
  const HilResult r =
      Hil({Scenario("driver-fault", 3.0,
                    "[[fault]]\nkind = \"driver_fault\"\nat_s = 1.0\n"
                    "duration_s = 0.3\n"),
           "--table", kPaper + "/table.bin", "--profile", Float32WithoutFaultLine(), "--out", out});
  ASSERT_EQ(r.status, 0) << r.err << r.j.dump();
  EXPECT_EQ(Slurp(out + "/firmware.toml").find("fault_line"), std::string::npos);
  ASSERT_EQ(r.j["faults"].size(), 1U);
  const json& f = r.j["faults"][0];
  EXPECT_TRUE(f["ok"].get<bool>()) << f.dump();
  EXPECT_LE(f["periods_to_detection"].get<int>(), 2) << f.dump();
  const json& fw = r.j["firmware"]["summary"];
  EXPECT_EQ(fw["watchdog"]["fault_line"]["trips"], 1) << fw.dump();
  EXPECT_GE(fw["watchdog"]["fault_line"]["periods"].get<int>(), 299) << fw.dump();
  // The shipped profile maps fault_line: the generated configuration routes it.
  const std::string out2 = ::testing::TempDir() + "/driver-fault-shipped";
  const HilResult s = Hil({Scenario("driver-fault-shipped", 2.0,
                                    "[[fault]]\nkind = \"driver_fault\"\nat_s = 1.0\n"
                                    "duration_s = 0.3\n"),
                           "--table", kPaper + "/table.bin", "--profile",
                           kProfiles + "modbus-float32.toml", "--out", out2});
  ASSERT_EQ(s.status, 0) << s.err;
  EXPECT_NE(Slurp(out2 + "/firmware.toml").find("\"fault_line\""), std::string::npos);
  EXPECT_EQ(s.j["firmware"]["summary"]["watchdog"]["fault_line"]["trips"], 1);
}

// Profiles whose safe state drives the coil, or whose command range the set-point signal
// cannot carry: refused by the harness and by --check-config alike, before anything runs,
// with the same words on every attempt (a refused run is as deterministic as a lockstep run).
TEST(DriverSafetyRunTest, UnsafeProfilesAreRefusedByBothSides) {
  const std::string dir = ::testing::TempDir();
  Write("falling-coil.csv", "E,mA\n0,2000\n10,0\n");
  std::string canopen = Slurp(kProfiles + "canopen-drive.toml");
  const auto swap = [](std::string t, const std::string& a, const std::string& b) {
    const auto at = t.find(a);
    EXPECT_NE(at, std::string::npos) << a;
    return t.replace(at, a.size(), b);
  };
  canopen =
      swap(canopen, "dbc = \"canopen-drive.dbc\"", "dbc = \"" + kProfiles + "canopen-drive.dbc\"");
  struct Case {
    std::string name, text, transport, words;
  };
  std::string no_enable = swap(canopen, "enable = \"DriveRpdo1.EnableOperation\"\n", "");
  no_enable =
      swap(no_enable, "calibration = \"canopen-coil.csv\"", "calibration = \"falling-coil.csv\"");
  const std::vector<Case> cases = {
      {"falling.toml",
       swap(canopen, "calibration = \"canopen-coil.csv\"", "calibration = \"falling-coil.csv\""),
       "can", "the calibration falls as E rises"},
      {"no-enable-falling.toml", no_enable, "can", "not the driver's off (0 mA)"},
      {"max-beyond.toml",
       swap(swap(canopen, "max = 2000.0", "max = 2250.0"), "calibration = \"canopen-coil.csv\"",
            "calibration = \"" + kProfiles + "canopen-coil.csv\""),
       "can", "command.max 2250 mA is beyond what DriveRpdo1.TargetCurrent"},
      {"modbus-max-beyond.toml",
       swap(swap(Slurp(kProfiles + "modbus-float32.toml"),
                 "command = { unit = 2, table = \"holding\", address = 0, type = \"float32\" }",
                 "command = { unit = 2, table = \"holding\", address = 0, type = \"int16\", "
                 "scale = 0.001 }"),
            "max = 24.0", "max = 40.0"),
       "modbus-tcp", "command.max 40 V is beyond what the command register"},
  };
  for (const Case& c : cases) {
    const std::string profile = Write(c.name, c.text);
    std::string first;
    for (int attempt = 0; attempt < 2; ++attempt) {
      // Fresh per process: an earlier run's summary must not pass for this one's.
      const std::string out =
          dir + "/refused-" + std::to_string(::getpid()) + "-" + c.name + std::to_string(attempt);
      std::filesystem::remove_all(out);
      const HilResult r =
          Hil({kSource + "/hil/scenarios/force-v1.toml", "--table", kPaper + "/table.bin",
               "--profile", profile, "--transport", c.transport, "--out", out});
      EXPECT_EQ(r.status, 2) << c.name << r.err;
      EXPECT_NE(r.err.find(c.words), std::string::npos) << c.name << ": " << r.err;
      EXPECT_NE(r.err.find(c.name + ":"), std::string::npos) << r.err;  // FILE:LINE
      if (attempt == 0) first = r.err;
      EXPECT_EQ(r.err, first) << c.name;
      FILE* summary = std::fopen((out + "/summary.json").c_str(), "r");
      EXPECT_EQ(summary, nullptr) << c.name << ": nothing is written";
      if (summary != nullptr) std::fclose(summary);
    }
    // The firmware refuses the same profile in its configuration.
    const std::string bus =
        c.transport == "can"
            ? "[can]\nlocal_bus = \"/tmp/none.sock\"\ninputs = [\"velocity\", \"demand\"]\n"
              "outputs = [\"command\"]\n"
            : "[modbus]\nmode = \"tcp\"\ninputs = [\"velocity\", \"demand\"]\n"
              "outputs = [\"command\"]\n";
    const std::string cfg = Write("fw-" + c.name, bus + "profile = \"" + profile + "\"\n");
    mrd::test::ChildProcess fw({kBin + "/mrd-firmware", "--check-config", cfg});
    EXPECT_EQ(fw.Wait(30.0), 2) << c.name;
    EXPECT_NE(fw.Stderr().find(c.words), std::string::npos) << c.name << ": " << fw.Stderr();
  }
}

// The shipped profiles prove their safe state: --check-config prints what the wire carries.
TEST(DriverSafetyRunTest, CheckConfigShowsTheSafeStateOnTheWire) {
  const std::string cfg =
      Write("fw-canopen.toml",
            "[can]\nlocal_bus = \"/tmp/none.sock\"\ninputs = [\"velocity\", \"demand\"]\n"
            "outputs = [\"command\", \"enable\"]\nprofile = \"" +
                kProfiles + "canopen-drive.toml\"\n");
  mrd::test::ChildProcess fw({kBin + "/mrd-firmware", "--check-config", cfg});
  ASSERT_EQ(fw.Wait(30.0), 0) << fw.Stderr();
  EXPECT_NE(fw.Stdout().find("safe state: can (canopen-drive): DriveRpdo1.TargetCurrent = 0 mA, "
                             "DriveRpdo1.EnableOperation = 0"),
            std::string::npos)
      << fw.Stdout();
  // A safe voltage that is not the driver's off is refused at its line.
  const std::string bad =
      Write("fw-canopen-safe.toml", Slurp(cfg) + "[safety]\nsafe_voltage = 1.0\n");
  mrd::test::ChildProcess b({kBin + "/mrd-firmware", "--check-config", bad});
  EXPECT_EQ(b.Wait(30.0), 2);
  EXPECT_NE(b.Stderr().find(bad + ":7: the safe state (safe_voltage 1 V) puts 200 mA"),
            std::string::npos)
      << b.Stderr();
}

// A driver without heartbeat supervision (its profile maps no heartbeat), with a status every
// 10 ms that the firmware must see within 50 ms: the simulated driver applies every command
// and sends its status at the DBC's cycle time, so force-v1 closes with no safe period after
// start-up.
TEST(DriverSafetyRunTest, ANoHeartbeatDriverWithA10msStatusClosesForceV1) {
  const std::string out = ::testing::TempDir() + "/no-heartbeat";
  std::vector<std::string> args = mrd::test::ForceV1();
  args.insert(args.end(), {"--profile", kTestProfiles + "no-heartbeat-driver.toml", "--out", out,
                           "--can-log", out + "-frames.log"});
  const HilResult r = Hil(args);
  ASSERT_EQ(r.status, 0) << r.err << r.j.dump();
  EXPECT_EQ(r.j["commands"], 20000);
  EXPECT_EQ(r.j["invariant_violations"], 0);
  EXPECT_GT(r.j["tracking"]["steps"].get<int>(), 19900);
  EXPECT_LT(r.j["tracking"]["error_reachable"].get<double>(), 0.05);
  const std::vector<Row> rows = Trace(out);
  std::size_t first = 0;
  while (first < rows.size() && rows[first].safe) ++first;
  int safe_after = 0;
  for (std::size_t k = first; k < rows.size(); ++k) safe_after += rows[k].safe ? 1 : 0;
  EXPECT_LT(first, 100U) << "start-up took " << first << " periods";
  EXPECT_EQ(safe_after, 0);
  const json& fw = r.j["firmware"]["summary"];
  EXPECT_EQ(fw["watchdog"]["fault_line"]["trips"], 0) << fw.dump();
  EXPECT_EQ(fw["safe_entries"], 0) << fw.dump();
  // The driver status (CoilState, 0x111) every 10 ms of the 20 s: 2000 frames (+ the first).
  std::ifstream log(out + "-frames.log");
  std::string line;
  int status = 0;
  while (std::getline(log, line)) status += line.find(" 111#") != std::string::npos ? 1 : 0;
  EXPECT_NEAR(status, 2000, 2);
  std::printf(
      "[ figures ] no-heartbeat driver: start-up %zu periods, %d safe after, tracking "
      "%.4f, %d status frames in 20 s\n",
      first, safe_after, r.j["tracking"]["error_reachable"].get<double>(), status);
}

// The modbus-float32 driver without heartbeat supervision (its heartbeat register removed),
// with (watchdog true) or without the communication watchdog its manual arms: a start-up write
// of the timeout and a keep-alive every 20 ms under a 100 ms watchdog.
std::string Float32WithoutHeartbeat(bool watchdog) {
  std::string text = Slurp(kProfiles + "modbus-float32.toml");
  const auto at = text.find("heartbeat = {");
  EXPECT_NE(at, std::string::npos);
  text.erase(at, text.find('\n', at) - at + 1);
  if (watchdog) {
    text +=
        "\n[[modbus.startup]]\nunit = 2\ntable = \"holding\"\naddress = 14\nvalue = 100\n"
        "\n[[modbus.periodic]]\nunit = 2\ntable = \"holding\"\naddress = 15\nvalue = 1\n"
        "period_ms = 20\nwatchdog_ms = 100\n";
  }
  return Write(watchdog ? "modbus-watchdog.toml" : "modbus-no-watchdog.toml", text);
}

// kill -9 of the firmware (0.5 s .. 1.0 s, real time) with a driver that has no heartbeat
// supervision: without a communication watchdog it keeps the last driving command (the coil
// stays energised); with the profile's keep-alive under its watchdog the driver drops the
// coil once the writes stop for 100 ms, and drives again when the restarted firmware writes.
TEST(DriverSafetyRunTest, AKilledFirmwaresDriverWatchdogDropsTheCoil) {
  for (const bool watchdog : {false, true}) {
    const std::string out = ::testing::TempDir() + "/kill-watchdog-" + std::to_string(watchdog);
    const HilResult r =
        Hil({Scenario("kill-watchdog", 3.0,
                      "[[fault]]\nkind = \"kill_firmware\"\nat_s = 0.5\n"
                      "duration_s = 0.5\n"),
             "--table", kPaper + "/table.bin", "--profile", Float32WithoutHeartbeat(watchdog),
             "--clock", "realtime", "--out", out});
    ASSERT_EQ(r.status, 0) << r.err << r.j.dump();
    EXPECT_EQ(r.j["firmware"]["starts"], 2) << r.j.dump();
    const std::vector<Row> rows = Trace(out);
    bool driving_at_kill = false;
    int window = 0, driven = 0, after = 0;
    for (const Row& row : rows) {
      if (row.t < 0.5) driving_at_kill = row.driven && !row.safe;  // the last step before it
      // From 150 ms after the kill (the 100 ms watchdog, 50 ms to spare) to its end.
      if (row.t >= 0.65 && row.t < 1.0) {
        ++window;
        driven += row.driven ? 1 : 0;
      }
      if (row.t >= 2.0) after += row.driven ? 1 : 0;  // the restarted firmware drives again
    }
    ASSERT_TRUE(driving_at_kill) << "watchdog " << watchdog << ": not driving when killed";
    EXPECT_GT(window, 300);
    if (watchdog) {
      EXPECT_EQ(driven, 0) << "the watchdog must drop the coil";
    } else {
      EXPECT_EQ(driven, window) << "without a watchdog the driver holds the coil";
    }
    EXPECT_GT(after, 0) << "watchdog " << watchdog << ": the restarted firmware never drove";
  }
}

}  // namespace
