// The per-period log: the runlog codec (round trip, truncation at every byte of the last
// block, CRC corruption, refusals) and the firmware's platform::PeriodLog (records = periods in a
// lockstep run, drops counted with a stalled writer, write errors, rotation).
#include "mrd/firmware/platform/period_log.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "fakes.hpp"
#include "host/test_util.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"
#include "mrd/runlog/runlog.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace platform {

// The writer's test seam (a friend of PeriodLog): a paused writer drains nothing.
struct PeriodLogTestAccess {
  static void PauseWriter(PeriodLog& log, bool paused) {
    log.paused_.store(paused, std::memory_order_release);
  }
};

}  // namespace platform

namespace {

constexpr std::int64_t kPeriod = 1'000'000;

PeriodRecord Sample(std::uint64_t k) {
  PeriodRecord r;
  r.period = k;
  r.t_ns = static_cast<std::int64_t>(k) * kPeriod;
  r.latency_ns = 1000 + static_cast<std::int64_t>(k);
  r.exec_ns = -static_cast<std::int64_t>(k);  // signed values survive
  r.frame[Input::kVelocity] = {1.5 * static_cast<double>(k), r.t_ns - 250};
  r.frame[Input::kDisplacement] = {-0.25, r.t_ns};
  // demand never sampled: NaN, age -1
  r.frame.fault_line = k % 2 == 1;
  r.frame.bus_faults = 0x40;
  r.read = IoStatus::kNoData;
  r.write = IoStatus::kFault;
  r.v_used = 3.0;
  r.x_used = -0.25;
  r.model_force = 123.456;
  r.force_demand = -7.0;
  r.e_law = std::numeric_limits<double>::quiet_NaN();
  r.command_v = 1.125;
  r.force_law = true;
  r.reachable = false;
  r.safe = k % 3 == 0;
  r.causes = 0x21;
  r.param_version = 7;
  return r;
}

// A file image: header, then blocks of `per_block` sample records.
std::string Image(std::uint64_t records, std::uint32_t per_block, std::uint64_t dropped = 0) {
  runlog::Header h;
  h.period_ns = kPeriod;
  h.source = "test";
  h.fields = platform::PeriodLogFields();
  std::string out = runlog::EncodeHeader(h);
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(per_block) * h.record_bytes());
  std::uint32_t seq = 0;
  for (std::uint64_t k = 0; k < records;) {
    std::uint32_t n = 0;
    for (; n < per_block && k < records; ++n, ++k) {
      platform::EncodePeriodRecord(Sample(k),
                                   buf.data() + static_cast<std::size_t>(n) * h.record_bytes());
    }
    runlog::EncodeBlock(seq++, dropped, buf.data(), n, h.record_bytes(), &out);
  }
  return out;
}

double Field(const runlog::Log& log, std::uint64_t r, const char* name) {
  const int i = runlog::FieldIndex(log.header, name);
  EXPECT_GE(i, 0) << name;
  return runlog::Value(log, log.header.Offsets(), r, static_cast<std::size_t>(i));
}

TEST(RunlogCodecTest, RoundTripKeepsHeaderFieldsAndEveryValue) {
  const std::string image = Image(10, 4, 3);
  runlog::Log log;
  std::string error;
  ASSERT_TRUE(runlog::DecodeLog(image, &log, &error)) << error;
  EXPECT_EQ(log.header.version, runlog::kVersion);
  EXPECT_EQ(log.header.period_ns, kPeriod);
  EXPECT_EQ(log.header.source, "test");
  const auto fields = platform::PeriodLogFields();
  ASSERT_EQ(log.header.fields.size(), fields.size());
  for (std::size_t i = 0; i < fields.size(); ++i) {
    EXPECT_EQ(log.header.fields[i].name, fields[i].name);
    EXPECT_EQ(log.header.fields[i].unit, fields[i].unit);
    EXPECT_EQ(log.header.fields[i].type, fields[i].type);
  }
  EXPECT_EQ(log.num_records, 10U);
  EXPECT_EQ(log.blocks, 3U);
  EXPECT_EQ(log.last_sequence, 2U);
  EXPECT_EQ(log.dropped, 3U);
  EXPECT_EQ(log.damage, runlog::Damage::kNone);
  EXPECT_EQ(log.valid_bytes, image.size());
  for (std::uint64_t k = 0; k < 10; ++k) {
    const PeriodRecord r = Sample(k);
    EXPECT_EQ(Field(log, k, "period"), static_cast<double>(k));
    EXPECT_EQ(Field(log, k, "t_ns"), static_cast<double>(r.t_ns));
    EXPECT_EQ(Field(log, k, "exec_ns"), static_cast<double>(r.exec_ns));
    EXPECT_EQ(Field(log, k, "v"), r.frame[Input::kVelocity].value);
    EXPECT_EQ(Field(log, k, "v_age_ns"), 250.0);
    EXPECT_EQ(Field(log, k, "x_age_ns"), 0.0);
    EXPECT_TRUE(std::isnan(Field(log, k, "demand")));
    EXPECT_EQ(Field(log, k, "demand_age_ns"), -1.0);
    EXPECT_EQ(Field(log, k, "fault_line"), k % 2 == 1 ? 1.0 : 0.0);
    EXPECT_EQ(Field(log, k, "bus_faults"), 64.0);
    EXPECT_EQ(Field(log, k, "read_status"), 1.0);
    EXPECT_EQ(Field(log, k, "write_status"), 2.0);
    EXPECT_EQ(Field(log, k, "v_used"), 3.0);
    EXPECT_EQ(Field(log, k, "model_force"), 123.456);
    EXPECT_TRUE(std::isnan(Field(log, k, "e_law")));
    EXPECT_EQ(Field(log, k, "command"), 1.125);
    EXPECT_EQ(Field(log, k, "reachable"), 0.0);
    EXPECT_EQ(Field(log, k, "safe"), k % 3 == 0 ? 1.0 : 0.0);
    EXPECT_EQ(Field(log, k, "causes"), 33.0);
    EXPECT_EQ(Field(log, k, "param_version"), 7.0);
  }
}

TEST(RunlogCodecTest, TruncatedAtEveryByteOfTheLastBlockReadsTheWholeBlocksBefore) {
  const std::string whole = Image(12, 5);  // blocks of 5, 5, 2
  runlog::Log full;
  std::string error;
  ASSERT_TRUE(runlog::DecodeLog(whole, &full, &error)) << error;
  const std::size_t last_block =
      whole.size() - runlog::kBlockHeaderBytes - 2 * full.header.record_bytes();
  for (std::size_t cut = last_block; cut < whole.size(); ++cut) {
    runlog::Log log;
    ASSERT_TRUE(runlog::DecodeLog(std::string_view(whole).substr(0, cut), &log, &error))
        << "cut " << cut << ": " << error;
    EXPECT_EQ(log.num_records, 10U) << "cut " << cut;
    EXPECT_EQ(log.blocks, 2U);
    EXPECT_EQ(log.valid_bytes, last_block);
    if (cut == last_block) {
      EXPECT_EQ(log.damage, runlog::Damage::kNone);
    } else {
      EXPECT_EQ(log.damage, runlog::Damage::kTruncated) << "cut " << cut;
      EXPECT_EQ(log.damage_block, 2U);
      EXPECT_EQ(log.damage_offset, last_block);
    }
    EXPECT_EQ(Field(log, 9, "period"), 9.0);
  }
}

TEST(RunlogCodecTest, CorruptBlockIsFoundByItsCrcAndStopsTheReading) {
  const std::string whole = Image(12, 5);
  runlog::Log full;
  std::string error;
  ASSERT_TRUE(runlog::DecodeLog(whole, &full, &error));
  const auto header =
      static_cast<std::size_t>(full.valid_bytes - full.blocks * runlog::kBlockHeaderBytes -
                               full.num_records * full.header.record_bytes());
  const std::size_t block1 = header + runlog::kBlockHeaderBytes + 5 * full.header.record_bytes();
  // Every byte of block 1 (header or payload), flipped, is caught.
  for (std::size_t at = block1;
       at < block1 + runlog::kBlockHeaderBytes + 5 * full.header.record_bytes(); at += 7) {
    std::string bad = whole;
    bad[at] = static_cast<char>(bad[at] ^ 0x10);
    runlog::Log log;
    ASSERT_TRUE(runlog::DecodeLog(bad, &log, &error));
    EXPECT_EQ(log.damage, runlog::Damage::kCorrupt) << "byte " << at;
    EXPECT_EQ(log.damage_block, 1U);
    EXPECT_EQ(log.damage_offset, block1);
    EXPECT_EQ(log.num_records, 5U);
  }
}

TEST(RunlogCodecTest, RefusesWhatIsNotAReadableLog) {
  const std::string whole = Image(3, 5);
  runlog::Log log;
  std::string error;
  EXPECT_FALSE(runlog::DecodeLog("t,x,v,E,f\n0,0,0,0,0\n", &log, &error));
  EXPECT_NE(error.find("not an mrd per-period log"), std::string::npos) << error;
  EXPECT_FALSE(runlog::DecodeLog("", &log, &error));
  std::string v2 = whole;
  v2[8] = 2;
  EXPECT_FALSE(runlog::DecodeLog(v2, &log, &error));
  EXPECT_NE(error.find("version 2"), std::string::npos) << error;
  for (std::size_t cut : {std::size_t{9}, std::size_t{14}, std::size_t{40}}) {
    EXPECT_FALSE(runlog::DecodeLog(std::string_view(whole).substr(0, cut), &log, &error));
    EXPECT_NE(error.find("truncated header"), std::string::npos) << cut << ": " << error;
  }
  std::string bad = whole;
  bad[40] = static_cast<char>(bad[40] ^ 1);  // inside the field table
  EXPECT_FALSE(runlog::DecodeLog(bad, &log, &error));
  EXPECT_NE(error.find("corrupt header"), std::string::npos) << error;
}

// Random damage (flipped bytes, cuts) anywhere: the decoder refuses or reads a consistent
// prefix, never beyond the bytes (under the debug-asan preset any stray read aborts).
TEST(RunlogCodecTest, RandomDamageIsRefusedOrReadAsAConsistentPrefix) {
  const std::string whole = Image(40, 7);
  std::mt19937 rng(29);
  for (int it = 0; it < 20000; ++it) {
    std::string m = whole;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) m[rng() % m.size()] = static_cast<char>(rng());
    if (rng() % 3 == 0) m.resize(rng() % m.size());
    runlog::Log log;
    std::string error;
    if (!runlog::DecodeLog(m, &log, &error)) {
      EXPECT_FALSE(error.empty());
      continue;
    }
    ASSERT_EQ(log.records.size(), log.num_records * log.header.record_bytes());
    ASSERT_LE(log.valid_bytes, m.size());
    ASSERT_EQ(log.damage == runlog::Damage::kNone, log.valid_bytes == m.size());
    const auto off = log.header.Offsets();
    for (std::uint64_t r = 0; r < log.num_records; ++r) {
      for (std::size_t i = 0; i < log.header.fields.size(); ++i)
        (void)runlog::Value(log, off, r, i);
    }
  }
}

// A lockstep loop with the log as its observer.
struct LoggedLoop {
  LockstepClock clock;
  SimulatedDamper plant{SpencerParams::Paper(), SimulationConfig{}, clock, kPeriod};
  Controller controller;
  Telemetry telemetry;
  Loop loop{clock, plant, plant, controller, telemetry, kPeriod};
  platform::PeriodLog log;
  LoggedLoop(const platform::LogConfig& config) {
    EXPECT_EQ(controller.Configure(test::DemoDamperTable(), {}), Error::kOk);
    log.Start(config, kPeriod, "test");
    loop.SetObserver(&log);
  }
};

TEST(PeriodLogTest, LockstepRunLogsEveryPeriodAndDropsNone) {
  test::TempDir dir;
  platform::LogConfig config;
  config.path = dir.File("run.mrdlog");
  LoggedLoop l(config);
  std::atomic<bool> stop{false};
  l.loop.Run(stop, 3'000'000'000);
  l.log.Stop();
  const platform::PeriodLogStats s = l.log.stats();
  EXPECT_EQ(l.loop.stats().ticks, 3000U);
  EXPECT_EQ(s.pushed, 3000U);
  EXPECT_EQ(s.written, 3000U);
  EXPECT_EQ(s.dropped, 0U);
  EXPECT_FALSE(s.failed);
  runlog::Log log;
  std::string error;
  ASSERT_TRUE(runlog::ReadLog(config.path, &log, &error)) << error;
  EXPECT_EQ(log.num_records, 3000U);
  EXPECT_EQ(log.dropped, 0U);
  EXPECT_EQ(log.damage, runlog::Damage::kNone);
  EXPECT_EQ(log.sequence_gaps, 0U);
  EXPECT_EQ(log.header.period_ns, kPeriod);
  for (std::uint64_t k = 0; k < 3000; k += 137) {
    EXPECT_EQ(Field(log, k, "period"), static_cast<double>(k));
    EXPECT_EQ(Field(log, k, "t_ns"), static_cast<double>((k + 1) * kPeriod));
  }
  // The last record is the loop's last period (the shutdown's safe command is no period).
  EXPECT_DOUBLE_EQ(Field(log, 2999, "model_force"), l.loop.stats().model_force_n);
  EXPECT_DOUBLE_EQ(Field(log, 2999, "force_demand"), l.loop.stats().force_demand_n);
  // The force law ran: the law's E is the command where not clamped, v_used finite.
  EXPECT_EQ(Field(log, 2999, "force_law"), 1.0);
  EXPECT_TRUE(std::isfinite(Field(log, 2999, "v_used")));
}

TEST(PeriodLogTest, StalledWriterDropsAndCountsWithoutBlockingTheLoop) {
  test::TempDir dir;
  platform::LogConfig config;
  config.path = dir.File("stall.mrdlog");
  config.ring_records = 16;
  config.block_records = 8;
  LoggedLoop l(config);
  platform::PeriodLogTestAccess::PauseWriter(l.log, true);
  for (int k = 1; k <= 100; ++k) {
    l.clock.Advance(kPeriod);
    l.loop.Tick(l.clock.Now());
  }
  EXPECT_EQ(l.loop.stats().ticks, 100U);
  EXPECT_EQ(l.log.stats().dropped, 84U);  // 16 fit the ring
  l.log.Stop();                           // drains the 16 even though paused
  const platform::PeriodLogStats s = l.log.stats();
  EXPECT_EQ(s.written, 16U);
  EXPECT_EQ(s.pushed, 100U);
  runlog::Log log;
  std::string error;
  ASSERT_TRUE(runlog::ReadLog(config.path, &log, &error)) << error;
  EXPECT_EQ(log.num_records, 16U);
  EXPECT_EQ(log.dropped, 84U);
  EXPECT_EQ(Field(log, 15, "period"), 15.0);  // the first 16 periods
}

TEST(PeriodLogTest, WriteErrorStopsTheLogOnceAndTheLoopRunsOn) {
  platform::LogConfig config;
  config.path = "/dev/full";  // every write: ENOSPC (the header's already)
  testing::internal::CaptureStderr();
  LoggedLoop l(config);
  std::atomic<bool> stop{false};
  l.loop.Run(stop, 500'000'000);
  l.log.Stop();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(l.loop.stats().ticks, 500U);
  EXPECT_TRUE(l.loop.stats().safe);
  const platform::PeriodLogStats s = l.log.stats();
  EXPECT_TRUE(s.failed);
  EXPECT_NE(s.error.find("No space left"), std::string::npos) << s.error;
  EXPECT_EQ(s.written, 0U);
  EXPECT_EQ(s.lost, 500U);
  EXPECT_EQ(err.find("logging stopped"), err.rfind("logging stopped")) << err;  // once
  EXPECT_NE(err.find("logging stopped"), std::string::npos) << err;
}

// The file size limit (RLIMIT_FSIZE: EFBIG, SIGXFSZ ignored) reached in the middle of the run.
TEST(PeriodLogTest, FileTooLargeMidRunStopsTheLogAndKeepsTheBlocksWritten) {
  test::TempDir dir;
  platform::LogConfig config;
  config.path = dir.File("efbig.mrdlog");
  config.block_records = 32;
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  struct sigaction ignore {
  }, previous{};
  ignore.sa_handler = SIG_IGN;
  sigaction(SIGXFSZ, &ignore, &previous);
  rlimit small = old;
  small.rlim_cur = 50000;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  testing::internal::CaptureStderr();
  LoggedLoop l(config);
  std::atomic<bool> stop{false};
  l.loop.Run(stop, 1'000'000'000);
  l.log.Stop();
  const std::string err = testing::internal::GetCapturedStderr();
  setrlimit(RLIMIT_FSIZE, &old);
  sigaction(SIGXFSZ, &previous, nullptr);
  EXPECT_EQ(l.loop.stats().ticks, 1000U);
  const platform::PeriodLogStats s = l.log.stats();
  EXPECT_TRUE(s.failed);
  EXPECT_NE(s.error.find("File too large"), std::string::npos) << s.error;
  EXPECT_GT(s.written, 0U);
  EXPECT_GT(s.lost, 0U);
  EXPECT_EQ(s.written + s.lost + s.dropped, 1000U);
  EXPECT_NE(err.find("logging stopped"), std::string::npos) << err;
  runlog::Log log;
  std::string error;
  ASSERT_TRUE(runlog::ReadLog(config.path, &log, &error)) << error;
  EXPECT_EQ(log.num_records, s.written);  // the blocks before the error are whole
  EXPECT_NE(log.damage, runlog::Damage::kCorrupt);
}

TEST(PeriodLogTest, UnwritableDirectoryStopsTheLogAtStart) {
  test::TempDir dir;
  const std::string file = dir.Write("plain", "x");
  platform::LogConfig config;
  config.path = file + "/log.mrdlog";  // a path under a regular file: ENOTDIR
  testing::internal::CaptureStderr();
  LoggedLoop l(config);
  std::atomic<bool> stop{false};
  l.loop.Run(stop, 100'000'000);
  l.log.Stop();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(l.loop.stats().ticks, 100U);
  EXPECT_TRUE(l.log.stats().failed);
  EXPECT_EQ(l.log.stats().lost, 100U);
  EXPECT_NE(err.find("cannot create the file"), std::string::npos) << err;
}

TEST(PeriodLogTest, ARestartKeepsTheEarlierLogAsPathDotOne) {
  test::TempDir dir;
  platform::LogConfig config;
  config.path = dir.File("restart.mrdlog");
  std::atomic<bool> stop{false};
  {
    LoggedLoop first(config);
    first.loop.Run(stop, 300'000'000);
    first.log.Stop();
  }
  {
    LoggedLoop second(config);
    second.loop.Run(stop, 200'000'000);
    second.log.Stop();
  }
  runlog::Log older, newer;
  std::string error;
  ASSERT_TRUE(runlog::ReadLog(config.path + ".1", &older, &error)) << error;
  ASSERT_TRUE(runlog::ReadLog(config.path, &newer, &error)) << error;
  EXPECT_EQ(older.num_records, 300U);
  EXPECT_EQ(newer.num_records, 200U);
  // files = 1: the new log replaces the old one.
  config.files = 1;
  {
    LoggedLoop third(config);
    third.loop.Run(stop, 100'000'000);
    third.log.Stop();
  }
  ASSERT_TRUE(runlog::ReadLog(config.path, &newer, &error)) << error;
  EXPECT_EQ(newer.num_records, 100U);
  ASSERT_TRUE(runlog::ReadLog(config.path + ".1", &older, &error)) << error;
  EXPECT_EQ(older.num_records, 300U);  // untouched
}

TEST(PeriodLogTest, RotationKeepsFilesWithContinuedSequences) {
  test::TempDir dir;
  platform::LogConfig config;
  config.path = dir.File("rot.mrdlog");
  config.max_bytes = 65536;  // ~2 blocks of 128 records
  config.block_records = 128;
  config.files = 3;
  LoggedLoop l(config);
  std::atomic<bool> stop{false};
  l.loop.Run(stop, 2'000'000'000);
  l.log.Stop();
  const platform::PeriodLogStats s = l.log.stats();
  EXPECT_EQ(s.written, 2000U);
  EXPECT_GT(s.files, 3U);
  EXPECT_FALSE(std::filesystem::exists(config.path + ".3"));
  std::uint64_t next_first = 0;
  std::uint64_t records = 0;
  for (const std::string& f : {config.path + ".2", config.path + ".1", config.path}) {
    runlog::Log log;
    std::string error;
    ASSERT_TRUE(runlog::ReadLog(f, &log, &error)) << error;
    EXPECT_LE(log.file_bytes, config.max_bytes);
    EXPECT_EQ(log.damage, runlog::Damage::kNone);
    if (next_first > 0) {
      EXPECT_EQ(log.first_sequence, next_first) << f;
    }
    next_first = log.last_sequence + 1;
    records += log.num_records;
  }
  EXPECT_EQ(next_first, s.blocks);  // the newest file ends with the last block
  EXPECT_LT(records, 2000U);        // older files were dropped by the rotation
}

// A path that is not a regular file (here a symlink to /dev/null, so a failure renames the
// link and never the device) is written on without rotation: no PATH.1, the node stays.
TEST(PeriodLogTest, ANonRegularFileIsNeverRotated) {
  test::TempDir dir;
  platform::LogConfig config;
  config.path = dir.File("null.mrdlog");
  ASSERT_EQ(::symlink("/dev/null", config.path.c_str()), 0);
  config.max_bytes = 65536;  // would rotate a regular file several times
  config.block_records = 128;
  config.files = 3;
  LoggedLoop l(config);
  std::atomic<bool> stop{false};
  l.loop.Run(stop, 2'000'000'000);
  l.log.Stop();
  const platform::PeriodLogStats s = l.log.stats();
  EXPECT_EQ(s.written, 2000U);
  EXPECT_FALSE(s.failed) << s.error;
  EXPECT_EQ(s.files, 1U);
  EXPECT_TRUE(std::filesystem::is_symlink(config.path));
  EXPECT_FALSE(std::filesystem::exists(config.path + ".1"));
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/null"));
}

}  // namespace
}  // namespace mrd::firmware
