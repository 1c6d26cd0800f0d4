// `mrd-hil run --out DIR` writes the firmware's per-period log as DIR/firmware.mrdlog: every
// period of the lockstep run, none dropped, its t_ns the run's time so each trace.csv row has
// the firmware period of the same time.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "host/test_util.hpp"
#include "mrd/runlog/runlog.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

TEST(HilLogTest, RunWritesTheFirmwareLogOnTheTraceTimeBase) {
  TempDir dir;
  const std::string out = dir.File("run");
  ChildProcess hil({std::string(MRD_BIN_DIR) + "/mrd-hil", "run",
                    std::string(MRD_SOURCE_DIR) + "/hil/scenarios/closed-loop-smoke.toml", "--out",
                    out});
  ASSERT_EQ(hil.Wait(180.0), 0) << hil.Stdout() << hil.Stderr();
  EXPECT_NE(hil.Stdout().find("firmware.mrdlog"), std::string::npos);
  runlog::Log log;
  std::string error;
  ASSERT_TRUE(runlog::ReadLog(out + "/firmware.mrdlog", &log, &error)) << error;
  EXPECT_EQ(log.damage, runlog::Damage::kNone);
  EXPECT_EQ(log.dropped, 0U);
  EXPECT_NE(log.header.source.find("clock grant"), std::string::npos) << log.header.source;
  const auto off = log.header.Offsets();
  const auto field = [&](const char* name) {
    return static_cast<std::size_t>(runlog::FieldIndex(log.header, name));
  };
  std::map<std::int64_t, std::uint64_t> by_time;  // t_ns -> record
  for (std::uint64_t r = 0; r < log.num_records; ++r) {
    EXPECT_EQ(runlog::Value(log, off, r, field("period")), static_cast<double>(r));
    by_time[static_cast<std::int64_t>(runlog::Value(log, off, r, field("t_ns")))] = r;
  }
  // Every trace row (t [s]) has the firmware's period of that time, whose command is the row's
  // command (as sent on mrd-native's wire: 1 mV resolution).
  std::ifstream trace(out + "/trace.csv");
  std::string line;
  std::getline(trace, line);
  ASSERT_EQ(line.rfind("t,", 0), 0U) << line;
  std::size_t command_col = 0;
  for (std::size_t at = 0; line.substr(at, line.find(',', at) - at) != "command"; ++command_col) {
    at = line.find(',', at);
    ASSERT_NE(at, std::string::npos) << "no command column: " << line;
    ++at;
  }
  std::uint64_t rows = 0, matched = 0, same_command = 0;
  while (std::getline(trace, line)) {
    ++rows;
    std::vector<std::string> cells;
    std::stringstream cells_in(line);
    for (std::string c; std::getline(cells_in, c, ',');) cells.push_back(c);
    ASSERT_GT(cells.size(), command_col) << line;
    const auto it = by_time.find(std::llround(std::stod(cells[0]) * 1e9));
    if (it == by_time.end()) continue;
    ++matched;
    const double fw = runlog::Value(log, off, it->second, field("command"));
    if (std::fabs(fw - std::stod(cells[command_col])) <= 0.0005 + 1e-9) ++same_command;
  }
  EXPECT_GE(rows, 1999U);
  EXPECT_EQ(matched, rows);
  EXPECT_EQ(same_command, rows);
  EXPECT_GE(log.num_records, rows);
}

// A gain changed with `mrd-firmware ctl set` while `mrd-hil run` runs is applied at a period
// boundary: the reply names the period, and the log's param_version steps from 0 to 1 exactly
// there. An out-of-range value is refused and changes nothing (the version stays 1).
TEST(HilLogTest, CtlSetDuringARunShowsInTheLogAtItsPeriod) {
  TempDir dir;
  const std::string out = dir.File("run");
  const std::string sock = out + "/ctl.sock";
  // 120 s of lockstep time: seconds of wall time, long enough to reach the running firmware.
  // No best-passive grid (--passive-step 0): its passive runs took half the test's time and
  // nothing here reads them.
  ChildProcess hil({std::string(MRD_BIN_DIR) + "/mrd-hil", "run",
                    std::string(MRD_SOURCE_DIR) + "/hil/scenarios/quarter-car-skyhook.toml",
                    "--set", "duration_s=120", "--passive-step", "0", "--out", out});
  const std::string ctl = std::string(MRD_BIN_DIR) + "/mrd-firmware ctl --socket " + sock + " ";
  CommandResult r;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  do {  // the socket answers once the firmware runs
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    r = test::Run(ctl + "get control.skyhook_gain");
  } while (r.status != 0 && std::chrono::steady_clock::now() < until);
  ASSERT_EQ(r.status, 0) << r.output << hil.Stderr();
  EXPECT_EQ(r.output.find("control.skyhook_gain = 60.0 "), 0U) << r.output;

  r = test::Run(ctl + "set control.skyhook_gain 40");
  ASSERT_EQ(r.status, 0) << r.output;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex("applied at period ([0-9]+)"))) << r.output;
  const std::uint64_t applied = std::stoull(m[1].str());
  r = test::Run(ctl + "set control.skyhook_gain 1e9");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("must be in"), std::string::npos) << r.output;
  EXPECT_EQ(test::Run(ctl + "get control.skyhook_gain").output.find("control.skyhook_gain = 40.0 "),
            0U);
  ASSERT_EQ(hil.Wait(300.0), 0) << hil.Stdout() << hil.Stderr();

  runlog::Log log;
  std::string error;
  ASSERT_TRUE(runlog::ReadLog(out + "/firmware.mrdlog", &log, &error)) << error;
  EXPECT_EQ(log.dropped, 0U);
  const auto off = log.header.Offsets();
  const auto version = static_cast<std::size_t>(runlog::FieldIndex(log.header, "param_version"));
  const auto period = static_cast<std::size_t>(runlog::FieldIndex(log.header, "period"));
  std::uint64_t first_changed = log.num_records, changed = 0;
  for (std::uint64_t k = 0; k < log.num_records; ++k) {
    const double v = runlog::Value(log, off, k, version);
    ASSERT_TRUE(v == 0.0 || v == 1.0) << "record " << k << ": version " << v;
    if (v == 1.0) {
      ++changed;
      if (first_changed == log.num_records) first_changed = k;
    }
  }
  ASSERT_LT(first_changed, log.num_records) << "the change never shows in the log";
  EXPECT_EQ(runlog::Value(log, off, first_changed, period), static_cast<double>(applied));
  EXPECT_EQ(changed, log.num_records - first_changed);  // from that period on, in every record
}

}  // namespace
}  // namespace mrd::test
