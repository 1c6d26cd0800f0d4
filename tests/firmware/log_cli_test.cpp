// The per-period log through the executables: mrd-firmware --log / [log] in every dry-run
// mode, kill -9 while logging, write errors, and `mrd log info|export|plot` with each kind of
// bad input (exit 2, clear message, nothing written).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "host/test_util.hpp"
#include "mrd/runlog/runlog.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }
std::string Mrd() { return Bin("mrd"); }

bool Has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// A 2 s lockstep dry run's log in dir/run.mrdlog.
std::string MakeLog(const TempDir& dir) {
  const std::string log = dir.File("run.mrdlog");
  const CommandResult r = test::Run(Firmware() + " --dry-run 2 --lockstep --log " + log);
  EXPECT_EQ(r.status, 0) << r.output;
  return log;
}

TEST(LogCliTest, LockstepDryRunLogsEveryPeriodAndInfoSaysSo) {
  TempDir dir;
  const std::string log = dir.File("run.mrdlog");
  CommandResult r = test::Run(Firmware() + " --dry-run 2 --lockstep --log " + log + " --json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "\"ticks\": 2000")) << r.output;
  EXPECT_TRUE(Has(r.output, "\"records_written\": 2000, \"dropped\": 0")) << r.output;
  r = test::Run(Mrd() + " log info " + log);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "records:  2000")) << r.output;
  EXPECT_TRUE(Has(r.output, "dropped:  0")) << r.output;
  EXPECT_TRUE(Has(r.output, "damage:   none")) << r.output;
  EXPECT_TRUE(Has(r.output, "model_force      f64  N")) << r.output;
  EXPECT_TRUE(Has(r.output, "periods:  0 to 1999 (2000 periods, 0 not in the file)")) << r.output;
}

TEST(LogCliTest, ConfigLogSectionIsRelativeToTheConfigAndTextSummaryReportsIt) {
  TempDir dir;
  const std::string cfg =
      dir.Write("fw.toml", "[log]\npath = \"cfg.mrdlog\"\nblock_records = 100\n");
  CommandResult r = test::Run(Firmware() + " --config " + cfg + " --dry-run 1 --lockstep");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "1000 records written (10 blocks, 1 file), 0 dropped")) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir.File("cfg.mrdlog")));
  // enabled = false: no log even with a path.
  const std::string off = dir.Write("off.toml", "[log]\nenabled = false\npath = \"off.mrdlog\"\n");
  r = test::Run(Firmware() + " --config " + off + " --dry-run 1 --lockstep --json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "\"log\": null")) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("off.mrdlog")));
}

TEST(LogCliTest, BadLogConfigIsRefusedWithFileAndLine) {
  TempDir dir;
  const std::string small =
      dir.Write("small.toml", "[log]\npath = \"x\"\nmax_bytes = 65536\nblock_records = 4096\n");
  CommandResult r = test::Run(Firmware() + " --config " + small + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(Has(r.output, small + ":3: [log] max_bytes 65536 is smaller")) << r.output;
  const std::string unknown = dir.Write("unknown.toml", "[log]\nsize = 3\n");
  r = test::Run(Firmware() + " --config " + unknown + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(Has(r.output, unknown + ":2: unknown key 'size' in [log]")) << r.output;
  const std::string files = dir.Write("files.toml", "[log]\nfiles = 0\n");
  r = test::Run(Firmware() + " --config " + files + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(Has(r.output, files + ":2: 'files' must be in [1, 1000]")) << r.output;
  r = test::Run(Firmware() + " --dry-run 1 --lockstep --log");
  EXPECT_EQ(r.status, 2) << r.output;
  // A file larger than what `mrd log` reads (4 GiB) is refused up front.
  const std::string huge = dir.Write("huge.toml", "[log]\nmax_bytes = 1099511627776\n");
  r = test::Run(Firmware() + " --config " + huge + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(Has(r.output, huge + ":2: 'max_bytes' must be in [65536, 4294967296]")) << r.output;
}

// A file-size limit (`ulimit -f`) is a write error of the log (EFBIG), not a signal that stops
// the loop: the run completes, the log says it stopped.
TEST(LogCliTest, AFileSizeLimitStopsTheLogNotTheLoop) {
  TempDir dir;
  const std::string log = dir.File("limited.mrdlog");
  const CommandResult r = test::Run("bash -c 'ulimit -f 16; exec " + Firmware() +
                                    " --dry-run 3 --lockstep --log " + log + "'");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "ticks:            3000")) << r.output;
  EXPECT_TRUE(Has(r.output, "STOPPED: write failed (File too large)")) << r.output;
  EXPECT_TRUE(Has(r.output, "final state:      safe")) << r.output;
}

// The log never truncates, moves or replaces a file that is not an mrd log: --log naming the
// configuration (or a table) is refused before anything runs, the file unchanged; a PATH.1
// that is another file is refused too. An mrd log at the path is still rotated to PATH.1.
TEST(LogCliTest, ALogPathThatIsAnotherFileIsRefusedAndLeftAlone) {
  TempDir dir;
  const std::string text = "[log]\nfiles = 1\n";
  const std::string cfg = dir.Write("fw.toml", text);
  CommandResult r =
      test::Run(Firmware() + " --config " + cfg + " --dry-run 1 --lockstep --log " + cfg);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(Has(r.output, "error: log " + cfg + ": " + cfg + " exists and is not an mrd log"))
      << r.output;
  EXPECT_EQ(FileBytes(cfg), text);
  const std::string table = dir.File("t.bin");
  ASSERT_EQ(test::Run(Firmware() + " --write-table " + table).status, 0);
  const std::string image = FileBytes(table);
  r = test::Run(Firmware() + " --dry-run 1 --lockstep --log " + table);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_EQ(FileBytes(table), image);
  EXPECT_FALSE(std::filesystem::exists(table + ".1"));
  // PATH.1 is someone's file: rotating into it would replace it.
  const std::string log = MakeLog(dir);
  dir.Write("run.mrdlog.1", "notes\n");
  const std::string two = dir.Write("two.toml", "[log]\nfiles = 2\n");
  r = test::Run(Firmware() + " --config " + two + " --dry-run 1 --lockstep --log " + log);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(Has(r.output, log + ".1 exists and is not an mrd log")) << r.output;
  EXPECT_EQ(FileBytes(log + ".1"), "notes\n");
  // An earlier log is an mrd log: rotated as before.
  std::filesystem::remove(log + ".1");
  r = test::Run(Firmware() + " --config " + two + " --dry-run 1 --lockstep --log " + log);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(test::Run(Mrd() + " log info " + log + ".1").status, 0);
}

// A FIFO at the log path: without a reader the log fails at once (no blocked start-up); with a
// reader that never reads, the log stops when the pipe is full and the run ends normally.
TEST(LogCliTest, AFifoLogNeverBlocksTheStartOrTheExit) {
  TempDir dir;
  const std::string fifo = dir.File("log.fifo");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  CommandResult r = test::Run("timeout 60 " + Firmware() + " --dry-run 1 --lockstep --log " + fifo);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "ticks:            1000")) << r.output;
  EXPECT_TRUE(Has(r.output, "a FIFO with no reader")) << r.output;
  const int reader = open(fifo.c_str(), O_RDONLY | O_NONBLOCK);  // opened, never read
  ASSERT_GE(reader, 0);
  r = test::Run("timeout 60 " + Firmware() + " --dry-run 5 --lockstep --log " + fifo);
  close(reader);
  EXPECT_EQ(r.status, 0) << r.output;  // timeout's 124 when the exit blocks on the pipe
  EXPECT_TRUE(Has(r.output, "ticks:            5000")) << r.output;
  EXPECT_TRUE(Has(r.output, "the reader does not keep up")) << r.output;
}

TEST(LogCliTest, FullDeviceStopsTheLogOnceTheRunCompletes) {
  const CommandResult r = test::Run(Firmware() + " --dry-run 1 --lockstep --log /dev/full");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "ticks:            1000")) << r.output;
  EXPECT_TRUE(Has(r.output, "STOPPED: write failed (No space left on device)")) << r.output;
  const auto first = r.output.find("logging stopped");
  ASSERT_NE(first, std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("logging stopped", first + 1), std::string::npos) << r.output;
  EXPECT_TRUE(Has(r.output, "final state:      safe")) << r.output;
}

TEST(LogCliTest, KillNineLeavesALogReadableUpToItsLastWholeBlock) {
  TempDir dir;
  const std::string log = dir.File("killed.mrdlog");
  // Real time, 10 minutes: it is killed long before. Blocks of 64 records, flushed every 20 ms.
  const std::string cfg = dir.Write("fw.toml",
                                    "[loop]\npriority = 0\nlock_memory = false\n"
                                    "[log]\nblock_records = 64\nflush_ms = 20\n");
  ChildProcess fw({Firmware().substr(Firmware().rfind(' ') + 1), "--config", cfg, "--dry-run",
                   "600", "--log", log});
  ASSERT_TRUE(fw.started());
  // Wait on the file's size (some blocks written), not on time; bounded so a broken firmware
  // fails the test instead of hanging it.
  std::uintmax_t size = 0;
  for (int i = 0; i < 6000 && size < 60000; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::error_code ec;
    size = std::filesystem::file_size(log, ec);
    if (ec) size = 0;
  }
  ASSERT_GE(size, 60000U) << fw.Stderr();
  fw.Signal(SIGKILL);
  EXPECT_EQ(fw.Wait(10.0), 128 + SIGKILL);
  const CommandResult r = test::Run(Mrd() + " log info " + log);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "format:   mrd per-period log, version 1")) << r.output;
  runlog::Log parsed;
  std::string error;
  ASSERT_TRUE(runlog::ReadLog(log, &parsed, &error)) << error;
  EXPECT_GE(parsed.num_records, 64U * 5);
  EXPECT_NE(parsed.damage, runlog::Damage::kCorrupt);
  EXPECT_TRUE(Has(r.output, "records:  " + std::to_string(parsed.num_records) + " ")) << r.output;
  // Every period from the first, none missing.
  EXPECT_TRUE(
      Has(r.output, "(" + std::to_string(parsed.num_records) + " periods, 0 not in the file)"))
      << r.output;
}

TEST(LogCliTest, ExportWritesTheChosenFieldsAndRefusesAnUnknownOne) {
  TempDir dir;
  const std::string log = MakeLog(dir);
  const std::string csv = dir.File("out.csv");
  CommandResult r =
      test::Run(Mrd() + " log export " + log + " --csv " + csv + " --fields period,t_ns,command");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string text = FileBytes(csv);
  EXPECT_EQ(text.substr(0, text.find('\n')), "period,t_ns,command");
  EXPECT_TRUE(Has(text, "\n0,1000000,")) << text.substr(0, 200);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 2001);
  r = test::Run(Mrd() + " log export " + log + " --csv " + csv);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(FileBytes(csv), "period,t_ns,latency_ns,exec_ns,v,v_age_ns"));
  const std::string other = dir.File("other.csv");
  r = test::Run(Mrd() + " log export " + log + " --csv " + other + " --fields period,bogus");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(Has(r.output, "unknown field 'bogus'; the log has: period, t_ns")) << r.output;
  EXPECT_FALSE(std::filesystem::exists(other));
}

TEST(LogCliTest, PlotWritesThePng) {
  TempDir dir;
  const std::string log = MakeLog(dir);
  const CommandResult r = test::Run(Mrd() + " log plot " + log + " --out " + dir.File("plots"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_GT(std::filesystem::file_size(dir.File("plots/run_time.png")), 1000U);
}

TEST(LogCliTest, TruncatedTailIsReadWithANote) {
  TempDir dir;
  const std::string whole = FileBytes(MakeLog(dir));
  const std::string cut = dir.File("cut.mrdlog");
  std::ofstream(cut, std::ios::binary) << whole.substr(0, whole.size() - 100);
  CommandResult r = test::Run(Mrd() + " log info " + cut);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(Has(r.output, "note: " + cut + ": truncated in block")) << r.output;
  r = test::Run(Mrd() + " log export " + cut + " --csv " + dir.File("cut.csv"));
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir.File("cut.csv")));
}

TEST(LogCliTest, BadInputIsRefusedWithExitTwoAndNothingWritten) {
  TempDir dir;
  const std::string whole = FileBytes(MakeLog(dir));
  runlog::Log parsed;
  std::string error;
  ASSERT_TRUE(runlog::DecodeLog(whole, &parsed, &error));
  const std::size_t header = whole.size() - parsed.blocks * runlog::kBlockHeaderBytes -
                             parsed.num_records * parsed.header.record_bytes();
  const auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir.File(name), std::ios::binary) << bytes;
    return dir.File(name);
  };
  std::string corrupt = whole;
  const std::size_t block1 =
      header + runlog::kBlockHeaderBytes + 256 * parsed.header.record_bytes();
  corrupt[block1 + 100] = static_cast<char>(corrupt[block1 + 100] ^ 0x55);
  std::string v9 = whole;
  v9[8] = 9;
  struct Case {
    std::string file, message;
  };
  const Case cases[] = {
      {write("text.csv", "t,x,v,E,f\n0,0,0,0,0\n"), "not an mrd per-period log"},
      {write("empty.mrdlog", ""), "not an mrd per-period log"},
      {write("v9.mrdlog", v9), "log format version 9; this program reads version 1"},
      {write("head.mrdlog", whole.substr(0, 30)), "truncated header"},
      {write("corrupt.mrdlog", corrupt),
       "corrupt block 1 at byte " + std::to_string(block1) + " (CRC mismatch)"},
      {dir.File("missing.mrdlog"), "cannot open"},
      {dir.File(""), "not a regular file"},
  };
  for (const Case& c : cases) {
    CommandResult r = test::Run(Mrd() + " log info " + c.file);
    EXPECT_EQ(r.status, 2) << c.file << ": " << r.output;
    EXPECT_TRUE(Has(r.output, c.message)) << c.file << ": " << r.output;
    const std::string csv = dir.File("bad.csv");
    r = test::Run(Mrd() + " log export " + c.file + " --csv " + csv);
    EXPECT_EQ(r.status, 2) << c.file << ": " << r.output;
    EXPECT_TRUE(Has(r.output, c.message)) << c.file << ": " << r.output;
    EXPECT_FALSE(std::filesystem::exists(csv));
    r = test::Run(Mrd() + " log plot " + c.file + " --out " + dir.File("badplot"));
    EXPECT_EQ(r.status, 2) << c.file << ": " << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir.File("badplot")));
  }
  // info on the corrupt file shows what came before the damage.
  const CommandResult r = test::Run(Mrd() + " log info " + dir.File("corrupt.mrdlog"));
  EXPECT_TRUE(Has(r.output, "records:  256 ")) << r.output;
}

}  // namespace
}  // namespace mrd::test
