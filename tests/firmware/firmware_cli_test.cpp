// mrd-firmware through the executable: help, dry runs, refused tables and configs.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "host/test_util.hpp"
#include "mrd/common/table.hpp"

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }

std::string WriteBuiltinTable(const TempDir& dir) {
  const std::string path = dir.File("table.bin");
  EXPECT_EQ(test::Run(Firmware() + " --write-table " + path).status, 0);
  return path;
}

void FlipByte(const std::string& path, std::size_t offset) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(static_cast<std::streamoff>(offset));
  char c = 0;
  f.get(c);
  f.seekp(static_cast<std::streamoff>(offset));
  f.put(static_cast<char>(c ^ 0x5A));
}

// Integer value of "key": N in the JSON counters, or -1.
long long JsonInt(const std::string& json, const std::string& key) {
  const std::string tag = "\"" + key + "\": ";
  const auto at = json.find(tag);
  return at == std::string::npos ? -1 : std::stoll(json.substr(at + tag.size()));
}

TEST(FirmwareCliTest, HelpDescribesDryRun) {
  const CommandResult r = test::Run(Firmware() + " --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("--dry-run SECONDS"), std::string::npos);
  EXPECT_NE(r.output.find("--table FILE"), std::string::npos);
}

TEST(FirmwareCliTest, LockstepDryRunPrintsJsonCounters) {
  TempDir dir;
  const std::string table = WriteBuiltinTable(dir);
  const CommandResult r =
      test::Run(Firmware() + " --table " + table + " --dry-run 3 --lockstep --json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("\"ticks\": 3000,"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"overruns\": 0,"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"final_safe_state\": true"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"stale_sensor\": {\"trips\": 0"), std::string::npos) << r.output;
}

TEST(FirmwareCliTest, RealTimeDryRunRunsAndCountsTime) {
  const CommandResult r = test::Run(Firmware() + " --dry-run 0.3 --json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("\"mode\": \"realtime\""), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"worst_latency_us\""), std::string::npos);
  // 300 periods in 0.3 s: each one ticked or, after an overrun on a loaded machine, skipped.
  const long long ticks = JsonInt(r.output, "ticks"), missed = JsonInt(r.output, "missed_periods");
  EXPECT_GT(ticks, 0) << r.output;
  EXPECT_LE(ticks, 300) << r.output;
  EXPECT_GE(ticks + missed, 300) << r.output;
}

TEST(FirmwareCliTest, CorruptedTableExitsNonZeroNamingCrc) {
  TempDir dir;
  const std::string table = WriteBuiltinTable(dir);
  FlipByte(table, kTableCoefficientsOffset + 2);
  const CommandResult r = test::Run(Firmware() + " --table " + table + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("refused: CRC mismatch"), std::string::npos) << r.output;
}

// A setting only the table can judge (a constant voltage beyond its range): the file, the
// setting and the range it must lie in.
TEST(FirmwareCliTest, ASettingOutsideTheTableNamesTheFileAndTheRange) {
  TempDir dir;
  const std::string config =
      dir.Write("cv.toml", "[control]\nlaw = \"constant\"\nconstant_voltage = 500\n");
  const CommandResult r = test::Run(Firmware() + " --config " + config + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(config + ": refused with table compiled-in"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("the constant voltage 500 V must lie in [E_min, E_max] = [0, 2.25] V"),
            std::string::npos)
      << r.output;
}

TEST(FirmwareCliTest, WrongMagicAndTruncatedTableNameTheirReasons) {
  TempDir dir;
  const std::string table = WriteBuiltinTable(dir);
  FlipByte(table, 0);
  CommandResult r = test::Run(Firmware() + " --table " + table + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("wrong magic"), std::string::npos) << r.output;
  const std::string shortfile = dir.Write("short.bin", "MRDT\x01");
  r = test::Run(Firmware() + " --table " + shortfile + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("wrong size"), std::string::npos) << r.output;
  r = test::Run(Firmware() + " --table " + dir.File("missing.bin") + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("cannot read"), std::string::npos) << r.output;
}

TEST(FirmwareCliTest, ConfigSelectsLawAndPeriod) {
  TempDir dir;
  const std::string cfg = dir.Write("fw.toml",
                                    "[loop]\nperiod_us = 500\n[control]\nlaw = \"skyhook\"\n"
                                    "skyhook_gain = 40.0\n[safety]\nsafe_voltage = 0.2\n");
  const CommandResult r =
      test::Run(Firmware() + " --config " + cfg + " --dry-run 1 --lockstep --json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("\"law\": \"skyhook\""), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"ticks\": 2000,"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"last_command_v\": 0.2,"), std::string::npos) << r.output;
}

// The chassis laws run on the dry-run plant (it serves body acceleration and wheel velocity);
// with a bus that serves neither, start-up refuses them (exit 2).
TEST(FirmwareCliTest, ChassisLawsRunDryAndAreRefusedWithoutTheirInputs) {
  TempDir dir;
  for (const char* law : {"groundhook", "groundhook-on-off", "hybrid", "add", "sh-add"}) {
    const std::string cfg = dir.Write(
        "fw.toml", std::string("[control]\nlaw = \"") + law + "\"\ngroundhook_gain = 20\n");
    const CommandResult r =
        test::Run(Firmware() + " --config " + cfg + " --dry-run 1 --lockstep --json");
    ASSERT_EQ(r.status, 0) << law << ": " << r.output;
    EXPECT_NE(r.output.find(std::string("\"law\": \"") + law + "\""), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("\"safe_entries\": 0"), std::string::npos) << law << ": " << r.output;
  }
  const std::string bus = dir.Write("bus.toml",
                                    "[control]\nlaw = \"add\"\n[can]\nlocal_bus = \"/tmp/none\"\n"
                                    "inputs = [\"velocity\"]\noutputs = [\"command\"]\n");
  const CommandResult r = test::Run(Firmware() + " --check-config " + bus);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("bus.toml: no bus serves input 'body_acceleration' (law \"add\")"),
            std::string::npos)
      << r.output;
}

TEST(FirmwareCliTest, BadConfigNamesFileLineAndKey) {
  TempDir dir;
  const std::string cfg = dir.Write("bad.toml", "[control]\nlaw = \"force\"\nfoo = 1\n");
  CommandResult r = test::Run(Firmware() + " --config " + cfg + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("bad.toml:3: unknown key 'foo' in [control]"), std::string::npos)
      << r.output;
  const std::string range = dir.Write("range.toml", "[control]\ne_max = 3.0\n");
  r = test::Run(Firmware() + " --config " + range + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("E_max 3"), std::string::npos) << r.output;
}

TEST(FirmwareCliTest, WithoutDryRunExplainsMissingBusDriver) {
  const CommandResult r = test::Run(Firmware());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--dry-run"), std::string::npos);
}

// The compiled-in demo table (a model of the reference damper) drives no real device unless
// --allow-demo-table says so; simulated endpoints (local bus, loopback Modbus) take it.
TEST(FirmwareCliTest, DemoTableDrivesNoRealDeviceUnlessAllowed) {
  TempDir dir;
  const std::string demo = WriteBuiltinTable(dir);
  const std::string tail = "inputs = [\"velocity\", \"demand\"]\noutputs = [\"command\"]\n";
  const struct {
    std::string name, text, device;
  } real[] = {
      {"can0.toml", "[can]\ninterface = \"can0\"\n" + tail, "CAN interface can0"},
      {"tcp.toml", "[modbus]\nhost = \"192.0.2.7\"\n" + tail, "Modbus TCP device 192.0.2.7"},
      {"rtu.toml", "[modbus]\nmode = \"rtu\"\ndevice = \"/dev/ttyS1\"\n" + tail,
       "Modbus RTU device /dev/ttyS1"},
  };
  for (const auto& c : real) {
    const std::string cfg = dir.Write(c.name, c.text);
    for (const std::string& table : {std::string(), " --table " + demo}) {
      const CommandResult r =
          test::Run(Firmware() + table + " --config " + cfg + " --duration 0.1");
      EXPECT_EQ(r.status, 2) << c.name << table << ": " << r.output;
      EXPECT_NE(r.output.find("is the demo table"), std::string::npos) << r.output;
      EXPECT_NE(r.output.find("refusing to drive " + c.device), std::string::npos) << r.output;
      EXPECT_NE(r.output.find("--allow-demo-table"), std::string::npos) << r.output;
    }
    // Told otherwise: the run goes on to open the device (which fails here, for its own reason).
    const CommandResult allowed =
        test::Run(Firmware() + " --config " + cfg + " --duration 0.1 --allow-demo-table");
    EXPECT_EQ(allowed.output.find("demo table"), std::string::npos) << allowed.output;
  }
  // A simulated endpoint (a local CAN bus nobody serves) is not a real device.
  const std::string local =
      dir.Write("local.toml", "[can]\nlocal_bus = \"" + dir.File("none.sock") + "\"\n" + tail);
  const CommandResult r = test::Run(Firmware() + " --config " + local + " --duration 0.1");
  EXPECT_EQ(r.output.find("demo table"), std::string::npos) << r.output;
}

// The packaged service's config ships without buses: --check-config (its ExecStartPre)
// refuses it and says where the guide is.
TEST(FirmwareCliTest, CheckConfigRefusesAConfigWithNothingToDrive) {
  TempDir dir;
  const std::string cfg = dir.Write("unconfigured.toml", "[control]\nlaw = \"force\"\n");
  const CommandResult r = test::Run(Firmware() + " --check-config " + cfg);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("unconfigured.toml: no device profile configured"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("/usr/share/doc/mrd-firmware/devices.md"), std::string::npos) << r.output;
  // The same file still serves a dry run.
  EXPECT_EQ(test::Run(Firmware() + " --config " + cfg + " --dry-run 0.1 --lockstep").status, 0);
}

// A board config with CAN and Modbus sections dry-runs with --ignore-buses, against the plant
// fitted to the NEES bench run (--plant, the harness's parameter file): the summary names the
// plant, and the plant changes the figures (it is not the reference damper's run).
TEST(FirmwareCliTest, BoardConfigDryRunsAgainstAFittedPlant) {
  TempDir dir;
  const std::string cfg = dir.Write(
      "board.toml",
      "[control]\nlaw = \"force\"\n[safety]\nvelocity_limit = 250\n"
      "[can]\ninterface = \"can0\"\ninputs = [\"velocity\", \"displacement\", \"demand\"]\n"
      "outputs = [\"heartbeat\", \"status\"]\n"
      "[modbus]\nmode = \"tcp\"\nhost = \"127.0.0.1\"\nport = 1502\nslave = 1\n"
      "inputs = [\"force\"]\noutputs = [\"command\"]\n");
  const std::string plant = std::string(MRD_SOURCE_DIR) + "/hil/scenarios/nees-damper/plant.toml";
  const std::string base = Firmware() + " --config " + cfg + " --dry-run 2 --lockstep --json";
  // Without --ignore-buses: refused, and told how.
  CommandResult r = test::Run(base);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--ignore-buses"), std::string::npos) << r.output;
  // With it, against the fitted plant.
  r = test::Run(base + " --ignore-buses --plant " + plant);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("--ignore-buses: dry run without the bus sections of " + cfg),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("\"plant\": \"" + plant + "\""), std::string::npos) << r.output;
  EXPECT_EQ(JsonInt(r.output, "ticks"), 2000) << r.output;
  EXPECT_GE(JsonInt(r.output, "unreachable_demands"), 0) << r.output;
  EXPECT_GE(JsonInt(r.output, "non_monotone_periods"), 0) << r.output;
  const auto rms = [](const std::string& out) {
    const std::string tag = "\"rms_model_error_n\": ";
    const auto at = out.find(tag);
    return at == std::string::npos ? -1.0 : std::stod(out.substr(at + tag.size()));
  };
  const CommandResult reference = test::Run(base + " --ignore-buses");
  ASSERT_EQ(reference.status, 0) << reference.output;
  EXPECT_NE(reference.output.find("\"plant\": \"reference damper (paper preset)\""),
            std::string::npos)
      << reference.output;
  EXPECT_GT(rms(r.output), 0.0);
  EXPECT_NE(rms(r.output), rms(reference.output)) << "the plant file changes the run";
  // A bad plant file: file, line, reason; exit 2.
  const std::string bad = dir.Write("bad.toml", "c0a = 1\nc0b = -3\n");
  r = test::Run(base + " --ignore-buses --plant " + bad);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("error: " + bad + ":2: "), std::string::npos) << r.output;
  // Both flags are for a dry run.
  r = test::Run(Firmware() + " --config " + cfg + " --duration 0.1 --ignore-buses");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--ignore-buses is for --dry-run"), std::string::npos) << r.output;
}

TEST(FirmwareCliTest, SigtermStopsTheLoopInTheSafeState) {
  const CommandResult r = test::Run("timeout --preserve-status -s TERM 0.5 " + Firmware() +
                                    " --dry-run 30 --json; echo status=$?");
  EXPECT_NE(r.output.find("\"final_safe_state\": true"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("status=0"), std::string::npos) << r.output;
}

// The loop's faulted periods per device and reason reach the summaries: a Modbus TCP peer
// nobody serves (connection refused) faults every period's read and write as "disconnected".
TEST(FirmwareCliTest, SummaryNamesTheReasonOfFaultedPeriods) {
  TempDir dir;
  const std::string cfg = dir.Write(
      "refused.toml",
      "[control]\nlaw = \"force\"\n[modbus]\nmode = \"tcp\"\nhost = \"127.0.0.1\"\nport = 1\n"
      "inputs = [\"velocity\", \"displacement\", \"demand\"]\noutputs = [\"command\"]\n");
  const CommandResult j =
      test::Run(Firmware() + " --config " + cfg + " --duration 0.05 --allow-demo-table --json");
  EXPECT_EQ(j.status, 0) << j.output;  // ended in the safe state
  const std::string periods =
      "\"faulted_periods\": {\"read\": {\"none\": 0, \"timeout\": 0, "
      "\"crc\": 0, \"disconnected\": ";
  const auto at = j.output.find(periods);
  ASSERT_NE(at, std::string::npos) << j.output;
  EXPECT_GT(std::stoll(j.output.substr(at + periods.size())), 0) << j.output;
  EXPECT_NE(j.output.find(
                "\"last_period_fault\": {\"read\": \"disconnected\", \"write\": \"disconnected\"}"),
            std::string::npos)
      << j.output;
  const CommandResult t =
      test::Run(Firmware() + " --config " + cfg + " --duration 0.05 --allow-demo-table");
  EXPECT_NE(t.output.find("(last disconnected), write "), std::string::npos) << t.output;
}

}  // namespace
}  // namespace mrd::test
