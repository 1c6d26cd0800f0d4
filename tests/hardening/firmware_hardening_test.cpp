// Issue 14 (hardening): mrd-firmware's dry-run limits, JSON summary, signals and write errors.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>

#include "firmware/app/summary_json.hpp"
#include "host/test_util.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "support/process.hpp"

extern char** environ;

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Defect 3: durations below one period or beyond the representable range never start.
TEST(FirmwareHardeningTest, DryRunsThatCouldNeverEndAreRefused) {
  for (const char* args : {"--dry-run 1e-12 --lockstep", "--dry-run 1e-10", "--dry-run 1e-4",
                           "--dry-run 1e10 --lockstep", "--dry-run 1e300"}) {
    const CommandResult r = test::Run("timeout 20 " + Firmware() + " " + args);
    EXPECT_EQ(r.status, 2) << args << ": " << r.output;
    EXPECT_NE(r.output.find("error: --dry-run"), std::string::npos) << r.output;
  }
  EXPECT_EQ(test::Run(Firmware() + " --dry-run 0.001 --lockstep").status, 0);
}

// Defect 7: the JSON summary is valid JSON for any table path.
TEST(FirmwareHardeningTest, JsonSummaryEscapesTheTablePath) {
  TempDir dir;
  const std::string table = dir.File("ta\"ble\\x.bin");
  ASSERT_EQ(test::Run(Firmware() + " --write-table '" + table + "'").status, 0);
  const std::string out = dir.File("out.json");
  const CommandResult r =
      test::Run(Firmware() + " --table '" + table + "' --dry-run 0.05 --lockstep --json > " + out);
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(Slurp(out));
  EXPECT_EQ(j["table"], table);
  EXPECT_EQ(j["final_safe_state"], true);
}

// Defect 7: non-finite figures (a diverging plant or table) become null, not 'inf'.
TEST(FirmwareHardeningTest, JsonSummaryWritesNonFiniteFiguresAsNull) {
  firmware::TelemetrySnapshot s;
  s.model_force_n = std::numeric_limits<double>::quiet_NaN();
  firmware::SummaryInfo info;
  info.table = "t";
  info.rms_model_error_n = std::numeric_limits<double>::infinity();
  const std::string text = firmware::SummaryJson(s, info);
  const nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_TRUE(j["rms_model_error_n"].is_null()) << text;
  EXPECT_TRUE(j["model_force_n"].is_null()) << text;
  EXPECT_EQ(text.find("inf"), std::string::npos);
}

// Starts mrd-firmware --dry-run 30 --json --ctl-socket SOCK with stdout into out; its pid, or
// -1 when it cannot be started. The socket appears once the signal handlers are installed.
pid_t SpawnDryRun(const std::string& out, const std::string& sock, const std::string& err = "") {
  const std::string bin = Firmware();
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (!err.empty()) {
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  char* argv[] = {const_cast<char*>(bin.c_str()),
                  const_cast<char*>("--dry-run"),
                  const_cast<char*>("30"),
                  const_cast<char*>("--json"),
                  const_cast<char*>("--ctl-socket"),
                  const_cast<char*>(sock.c_str()),
                  nullptr};
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, bin.c_str(), &fa, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&fa);
  return rc == 0 ? pid : -1;
}

// The still-running dry run pid stopped with SIGTERM: it exits 0 in the safe state, before the
// end of its 30 s; its JSON summary (in out).
nlohmann::json StopAndCheck(pid_t pid, const std::string& out) {
  int status = 0;
  EXPECT_EQ(waitpid(pid, &status, WNOHANG), 0)
      << "the signal stopped the firmware (" << status << ")";
  kill(pid, SIGTERM);
  EXPECT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  const nlohmann::json j = nlohmann::json::parse(Slurp(out), nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << Slurp(out);
  if (j.is_discarded()) return j;
  EXPECT_EQ(j["final_safe_state"], true);
  EXPECT_LT(j["ticks"].get<long long>(), 30000) << "SIGTERM did not stop it";
  return j;
}

// Runs the dry run, sends sig once its handlers are installed; returns the wait status.
int RunAndSignal(int sig, const std::string& out) {
  // One per run: a fresh path to wait for.
  const std::string sock = out + "." + std::to_string(sig) + ".sock";
  const pid_t pid = SpawnDryRun(out, sock);
  if (pid < 0) return -1;
  test::WaitForPath(sock, 20.0);  // on a timeout the signal still goes (the test then fails)
  kill(pid, sig);
  int status = 0;
  waitpid(pid, &status, 0);
  return status;
}

// Defect 11: every catchable terminating signal ends in the safe-state shutdown (SIGHUP is
// a reload: below).
TEST(FirmwareHardeningTest, EveryTerminatingSignalEndsInTheSafeState) {
  TempDir dir;
  for (const int sig : {SIGINT, SIGTERM, SIGQUIT, SIGPIPE, SIGUSR1, SIGUSR2, SIGALRM, SIGVTALRM,
                        SIGPROF, SIGXCPU, SIGPWR}) {
    const std::string out = dir.File("out.json");
    const int status = RunAndSignal(sig, out);
    ASSERT_TRUE(WIFEXITED(status)) << "signal " << sig << " killed it (status " << status << ")";
    EXPECT_EQ(WEXITSTATUS(status), 0) << "signal " << sig;
    const nlohmann::json j = nlohmann::json::parse(Slurp(out));
    EXPECT_EQ(j["final_safe_state"], true) << "signal " << sig;
    EXPECT_LT(j["ticks"].get<long long>(), 30000) << "signal " << sig << " did not stop it";
  }
}

// SIGXFSZ (a file past `ulimit -f`) is ignored by design (the log's write fails, the loop
// runs on: mrd-firmware --help): the loop still runs after it, and a later SIGTERM stops it in
// the safe state. (It sat in the list above, where the 30 s dry run ran to its end and passed
// only because a loaded loop missed some of its 30000 ticks.)
TEST(FirmwareHardeningTest, SigxfszIsIgnoredAndTheLoopRunsOn) {
  TempDir dir;
  const std::string out = dir.File("out.json"), sock = dir.File("ctl.sock");
  const pid_t pid = SpawnDryRun(out, sock);
  ASSERT_GT(pid, 0);
  if (!test::WaitForPath(sock, 20.0)) {  // the handlers are installed once the socket is there
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    FAIL() << "the firmware did not open its control socket";
  }
  kill(pid, SIGXFSZ);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  StopAndCheck(pid, out);
}

// SIGHUP reloads (config and table) and does not stop the loop; a later SIGTERM stops it in
// the safe state with the reload counted.
TEST(FirmwareHardeningTest, SighupReloadsAndKeepsRunning) {
  TempDir dir;
  const std::string out = dir.File("out.json"), err = dir.File("err.txt");
  // The control socket appears after the signal handlers are installed: it marks "ready for
  // SIGHUP" (a fixed sleep raced a slow start: SIGHUP's default action killed the process).
  const std::string sock = dir.File("ctl.sock");
  const pid_t pid = SpawnDryRun(out, sock, err);
  ASSERT_GT(pid, 0);
  if (!test::WaitForPath(sock, 20.0)) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    FAIL() << "the firmware did not open its control socket: " << Slurp(err);
  }
  kill(pid, SIGHUP);
  // Upper bound only (the reload message comes within a few periods).
  for (int i = 0; i < 2000 && Slurp(err).find("reloaded") == std::string::npos; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_NE(Slurp(err).find("mrd-firmware: reloaded config (none) and table compiled-in"),
            std::string::npos)
      << Slurp(err);
  const nlohmann::json j = StopAndCheck(pid, out);
  if (!j.is_discarded()) {
    EXPECT_EQ(j["parameters"]["reloads"], 1);
  }
}

// Defect 11: a result that cannot be written is an error.
TEST(FirmwareHardeningTest, JsonToAFullDeviceFails) {
  if (access("/dev/full", W_OK) != 0) GTEST_SKIP() << "no /dev/full";
  const CommandResult r =
      test::Run(std::string("(") + Firmware() + " --dry-run 0.01 --lockstep --json > /dev/full)");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("error"), std::string::npos) << r.output;
}

// Consistency: the committed reference is the generated one, so the two cannot drift.
TEST(FirmwareHardeningTest, CommittedConfigReferenceEqualsTheGeneratedOne) {
  const std::string generated = firmware::platform::ConfigReference();
  ASSERT_FALSE(generated.empty());
  EXPECT_EQ(Slurp(std::string(MRD_SOURCE_DIR) + "/docs/firmware_config.md"), generated)
      << "regenerate: build/bin/mrd-firmware --print-config-reference > docs/firmware_config.md";
  const CommandResult r = test::Run(Firmware() + " --print-config-reference");
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.output, generated);
}

// Consistency: every default the reference states parses back to the built-in default.
TEST(FirmwareHardeningTest, ConfigReferenceDefaultsAreTheBuiltInDefaults) {
  const std::string ref = firmware::platform::ConfigReference();
  std::string toml, line;
  std::istringstream in(ref);
  int keys = 0;
  while (std::getline(in, line)) {
    // A bus section's presence enables that bus, which then needs its routing (inputs,
    // outputs, an endpoint): defaults alone are no valid bus. The bus sections come last.
    if (line == "## [can]") break;
    if (line.rfind("## [", 0) == 0) toml += line.substr(3) + "\n";
    if (line.rfind("| `", 0) != 0) continue;
    const auto k0 = line.find('`') + 1, k1 = line.find('`', k0);
    const auto d0 = line.find("| ", k1) + 2, d1 = line.find(" |", d0);
    const std::string def = line.substr(d0, d1 - d0);
    if (def.front() != '`') continue;  // "table's": no fixed default
    toml += line.substr(k0, k1 - k0) + " = " + def.substr(1, def.size() - 2) + "\n";
    ++keys;
  }
  EXPECT_GE(keys, 20) << ref;
  firmware::platform::FirmwareConfig parsed, defaults;
  std::string error;
  ASSERT_TRUE(firmware::platform::ParseConfig(toml, "reference", &parsed, &error)) << error << "\n"
                                                                                   << toml;
  EXPECT_EQ(parsed.period_ns, defaults.period_ns);
  EXPECT_EQ(parsed.priority, defaults.priority);
  EXPECT_EQ(parsed.controller.law.force_limit, defaults.controller.law.force_limit);
  EXPECT_EQ(parsed.controller.watchdog.max_age_ns, defaults.controller.watchdog.max_age_ns);
  EXPECT_EQ(parsed.simulation.demand_amplitude_n, defaults.simulation.demand_amplitude_n);
  EXPECT_EQ(parsed.simulation.body_phase_rad, defaults.simulation.body_phase_rad);
  EXPECT_EQ(parsed.simulation.substeps, defaults.simulation.substeps);
}

}  // namespace
}  // namespace mrd::test
