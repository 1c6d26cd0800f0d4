// `mrd-hil run --out DIR` writes the firmware's per-period log as DIR/firmware.mrdlog: every
// period of the lockstep run, none dropped, its t_ns the run's time so each trace.csv row has
// the firmware period of the same time.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
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

}  // namespace
}  // namespace mrd::test
