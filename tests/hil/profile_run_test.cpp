// `mrd-hil run --profile`: the harness plays the driver in a device profile's messages and the
// firmware runs the same profile (labels profile, fieldbus, hil): a hand-written test driver
// (tests/data/profiles/test-driver.*: Motorola and Intel signals, offsets, extended ids, a sum
// checksum, a CRC-8 of another polynomial, no firmware status) closes the loop on force-v1
// like the native protocol, lockstep and in real time; profile errors are refused. The shipped
// pwm-enable profile (the set-point as a sysfs PWM duty, the enable on a GPIO line, sensors over
// CAN) does the same through the harness's sysfs-ABI tree, deterministically in lockstep.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "hil/hil_run.hpp"
#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;
using nlohmann::json;

const std::string kBin = MRD_BIN_DIR;
const std::string kSource = MRD_SOURCE_DIR;
const std::string kScn = kSource + "/hil/scenarios/";
const std::string kPaper = MRD_PAPER_DIR;
const std::string kTestDriver = kSource + "/tests/data/profiles/test-driver.toml";
const std::string kPwmEnable = kSource + "/firmware/profiles/pwm-enable.toml";

using mrd::test::ForceV1;
using mrd::test::Hil;
using mrd::test::HilResult;

TEST(ProfileRunTest, TestDriverProfileTracksLikeTheNativeProtocolInLockstep) {
  const HilResult native = Hil(ForceV1());
  std::vector<std::string> args = ForceV1();
  args.insert(args.end(), {"--profile", kTestDriver});
  const HilResult driver = Hil(args);
  ASSERT_EQ(native.status, 0) << native.err;
  ASSERT_EQ(driver.status, 0) << driver.err;
  EXPECT_EQ(driver.j["invariant_violations"], 0);
  EXPECT_EQ(driver.j["commands"], 20000);
  const double n = native.j["tracking"]["error_reachable"].get<double>();
  const double d = driver.j["tracking"]["error_reachable"].get<double>();
  EXPECT_NEAR(d, n, 0.005) << "native " << n << ", test driver " << d;
  const json& fw = driver.j["firmware"]["summary"];
  EXPECT_EQ(fw["devices"]["can"]["rx_rejected"], 0);
  EXPECT_EQ(fw["safe_entries"], 0);
  EXPECT_EQ(fw["clock"]["missed_grants"], 0);
}

// Real time: every frame of the profile accepted on both sides and no fault but staleness (a
// loaded host may delay a period past max_age now and then: the figure with 0 safe entries is
// measured on a quiet machine, docs/benchmarks.md).
TEST(ProfileRunTest, TestDriverProfileRunsTenSecondsInRealTime) {
  std::vector<std::string> args = ForceV1();
  args.insert(args.end(), {"--profile", kTestDriver, "--clock", "realtime"});
  // The first 10 s of force-v1's excitation; in real time the tracking bound of the lockstep
  // scenario is not the point: the protocol runs without a safe entry.
  const std::string scn = ::testing::TempDir() + "/force-v1-10s.toml";
  {
    FILE* f = std::fopen(scn.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fprintf(f,
                 "name = \"force-v1-10s\"\nduration_s = 10.0\n[excitation]\nkind = \"csv\"\n"
                 "file = \"%s/v1.csv\"\ndemand_column = \"f\"\n[control]\nlaw = \"force\"\n"
                 "[pass]\nmax_invariant_violations = 0\n",
                 kPaper.c_str());
    std::fclose(f);
  }
  args[0] = scn;
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
  // How many of the 10 000 periods carry a fresh command is a rate: it depends on how the host
  // schedules the two processes (9 543 beside a CI run at load 2, 8 700 at load 4 to 9), so it
  // is measured (docs/benchmarks.md), not asserted. What holds under any load: the firmware
  // never went silent for the command timeout, and it sent no more commands than it ran ticks.
  EXPECT_EQ(r.j["command_timeouts"], 0);
  const auto commands = r.j["commands"].get<std::uint64_t>();
  EXPECT_GT(commands, 0U);
  EXPECT_LE(commands, fw["ticks"].get<std::uint64_t>()) << fw.dump();
}

TEST(ProfileRunTest, ABadProfileIsRefusedBeforeAnythingStarts) {
  std::vector<std::string> args = ForceV1();
  args.insert(args.end(), {"--profile", kSource + "/tests/data/profiles/test-driver.dbc"});
  const HilResult r = Hil(args);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("test-driver.dbc:"), std::string::npos) << r.err;
  args = ForceV1();
  args.insert(args.end(), {"--profile", kTestDriver, "--transport", "modbus-tcp"});
  const HilResult m = Hil(args);
  EXPECT_EQ(m.status, 2);
  EXPECT_NE(m.err.find("needs --transport can"), std::string::npos) << m.err;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The first `seconds` of force-v1's excitation as a scenario file in the test's temp dir.
std::string ForceV1Prefix(double seconds) {
  const std::string scn = ::testing::TempDir() + "/force-v1-" + std::to_string(seconds) + "s.toml";
  std::ofstream(scn) << "name = \"force-v1-prefix\"\nduration_s = " << seconds
                     << "\n[excitation]\nkind = \"csv\"\nfile = \"" << kPaper
                     << "/v1.csv\"\ndemand_column = \"f\"\n[control]\nlaw = \"force\"\n"
                        "[pass]\nmax_invariant_violations = 0\n";
  return scn;
}

// The set-point as a PWM duty (the harness reads the tick's duty from the sysfs-ABI tree after
// the tick's status frame), the enable and heartbeat on the simulated GPIO chip.
TEST(ProfileRunTest, PwmEnableProfileTracksLikeTheNativeProtocolInLockstep) {
  const HilResult native = Hil(ForceV1());
  std::vector<std::string> args = ForceV1();
  args.insert(args.end(), {"--profile", kPwmEnable});
  const HilResult pwm = Hil(args);
  ASSERT_EQ(native.status, 0) << native.err;
  ASSERT_EQ(pwm.status, 0) << pwm.err << pwm.j.dump();
  EXPECT_EQ(pwm.j["invariant_violations"], 0);
  EXPECT_EQ(pwm.j["commands"], 20000);
  const double n = native.j["tracking"]["error_reachable"].get<double>();
  const double d = pwm.j["tracking"]["error_reachable"].get<double>();
  EXPECT_NEAR(d, n, 0.005) << "native " << n << ", pwm-enable " << d;
  // Every step's duty read, none breaking the ABI (duty > period, another period/polarity).
  EXPECT_EQ(pwm.j["ports"]["pwm"]["received"], 20000);
  EXPECT_EQ(pwm.j["ports"]["pwm"]["rejected"], 0);
  EXPECT_EQ(pwm.j["ports"]["can"]["rejected"], 0);
  const json& fw = pwm.j["firmware"]["summary"];
  EXPECT_EQ(fw["devices"]["pwm"]["tx_failed"], 0);
  EXPECT_GT(fw["devices"]["pwm"]["tx_ok"].get<int>(), 1000);  // duty written when it changed
  EXPECT_EQ(fw["devices"]["can"]["rx_rejected"], 0);
  EXPECT_EQ(fw["safe_entries"], 0);
  EXPECT_EQ(fw["clock"]["missed_grants"], 0);
}

// Lockstep with a PWM output gives the same trace run after run (no wall time in it).
TEST(ProfileRunTest, PwmEnableLockstepIsDeterministic) {
  const std::string scn = ForceV1Prefix(3.0);
  std::string traces[2];
  for (int i = 0; i < 2; ++i) {
    const std::string out = ::testing::TempDir() + "/pwm-lockstep-" + std::to_string(i);
    const HilResult r =
        Hil({scn, "--table", kPaper + "/table.bin", "--profile", kPwmEnable, "--out", out});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.j["commands"], 3000);
    traces[i] = Slurp(out + "/trace.csv");
  }
  EXPECT_GT(traces[0].size(), 3000U * 20U);
  EXPECT_TRUE(traces[0] == traces[1]) << "the two lockstep traces differ";
}

// Real time: as the test driver's: no fault but staleness, the duty read every step.
TEST(ProfileRunTest, PwmEnableProfileRunsTenSecondsInRealTime) {
  const HilResult r = Hil({ForceV1Prefix(10.0), "--table", kPaper + "/table.bin", "--profile",
                           kPwmEnable, "--clock", "realtime"});
  ASSERT_EQ(r.status, 0) << r.err << r.j.dump();
  EXPECT_EQ(r.j["clock"], "realtime");
  EXPECT_EQ(r.j["invariant_violations"], 0);
  const json& fw = r.j["firmware"]["summary"];
  EXPECT_EQ(fw["devices"]["can"]["rx_rejected"], 0) << fw.dump();
  EXPECT_EQ(fw["devices"]["pwm"]["tx_failed"], 0) << fw.dump();
  EXPECT_EQ(r.j["ports"]["can"]["rejected"], 0);
  EXPECT_EQ(r.j["ports"]["pwm"]["rejected"], 0);
  for (const auto& [cause, w] : fw["watchdog"].items()) {
    if (cause != "stale_sensor") {
      EXPECT_EQ(w["trips"], 0) << cause;
    }
  }
  EXPECT_GT(r.j["commands"].get<int>(), 9000);
  std::printf("pwm-enable real time: safe_entries %d, safe_commands %d\n",
              fw["safe_entries"].get<int>(), r.j["safe_commands"].get<int>());
}

// Lockstep reads the duty after the tick's status frame: a PWM profile without one is refused.
TEST(ProfileRunTest, APwmProfileWithoutAFirmwareStatusIsRefusedInLockstep) {
  std::string text = Slurp(kPwmEnable);
  for (const char* role :
       {"status_safe = ", "status_causes = ", "status_overruns = ", "status_safe_entries = "}) {
    const auto at = text.find(role);
    ASSERT_NE(at, std::string::npos) << role;
    text.insert(at, "# ");
  }
  for (const std::string f : {"pwm-enable.dbc", "pwm-enable-coil.csv"}) {
    const auto at = text.find("\"" + f + "\"");
    ASSERT_NE(at, std::string::npos) << f;
    text.replace(at, f.size() + 2, "\"" + kSource + "/firmware/profiles/" + f + "\"");
  }
  const std::string path = ::testing::TempDir() + "/pwm-no-status.toml";
  std::ofstream(path) << text;
  std::vector<std::string> args = ForceV1();
  args.insert(args.end(), {"--profile", path});
  const HilResult r = Hil(args);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("lockstep with a [pwm] output needs a firmware status message"),
            std::string::npos)
      << r.err;
}

}  // namespace
