#pragma once
// The per-period log (docs/logging.md): the loop's PeriodObserver pushes each PeriodRecord
// into a preallocated single-producer single-consumer ring (copy + one release store; a full
// ring drops the record and counts it); a non-real-time writer thread drains the ring into
// blocks of the runlog format (common/runlog) and appends them to the file, rotating at
// max_bytes and keeping `files` files (a regular file only: a device such as /dev/null, a FIFO
// or a socket is written on without rotation; a FIFO without a reader, or whose reader stops
// reading for 200 ms, fails the log instead of blocking). A write error (ENOSPC, EFBIG, EROFS,
// EIO, ...) stops the log: one line on stderr, the loop keeps running, later records are
// counted as lost. A file at the path that is not an mrd log is never truncated or moved.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "mrd/firmware/period_hooks.hpp"
#include "mrd/firmware/platform/log_config.hpp"
#include "mrd/runlog/runlog.hpp"

namespace mrd::firmware::platform {

// "" when the log may write at config.path; else why not (exit 2 at start-up): a directory,
// or a file at PATH or a rotation name PATH.1 .. that exists and is not an mrd log (the log
// would truncate or move it: a configuration, a table).
std::string CheckLogPath(const LogConfig& config);

// The record's fields (name, type, unit) in file order, and their encoding.
std::vector<runlog::Field> PeriodLogFields();
// Encodes r into out (runlog::Header::record_bytes of PeriodLogFields() bytes). Ages are
// t_ns - stamp [ns], -1 for a signal never sampled.
void EncodePeriodRecord(const PeriodRecord& r, std::uint8_t* out);

struct PeriodLogStats {
  std::uint64_t pushed = 0;   // records the loop handed over
  std::uint64_t dropped = 0;  // ring full: not logged
  std::uint64_t written = 0;  // records in blocks written to files
  std::uint64_t lost = 0;     // drained after the log stopped (write error): not logged
  std::uint64_t blocks = 0;
  std::uint64_t bytes = 0;  // all files
  std::uint32_t files = 0;  // files opened (rotations + 1)
  bool failed = false;      // the log stopped on an error
  std::string error;        // why ("" when not failed)
};

class PeriodLog final : public PeriodObserver {
 public:
  PeriodLog() = default;
  ~PeriodLog() override;
  PeriodLog(const PeriodLog&) = delete;
  PeriodLog& operator=(const PeriodLog&) = delete;

  // Allocates and touches the ring (so mlockall holds it resident), shifts a non-empty
  // regular file at config.path from an earlier start to PATH.1 (files > 1), opens config.path and
  // writes the header (period_ns and source go into it), starts the writer thread. A file that
  // cannot be opened is a failed log (stats().failed, one line on stderr): the loop runs
  // without it (OnPeriod then only counts). Not real-time. Call once.
  void Start(const LogConfig& config, std::int64_t period_ns, const std::string& source);
  // Real-time safe: copies the record into the ring, or counts it dropped when the ring is
  // full. Never blocks, never allocates.
  void OnPeriod(const PeriodRecord& record) override;
  // Drains the ring, writes the last partial block, closes the file, joins the writer.
  // Idempotent. Not real-time.
  void Stop();
  // Counters (after Stop: final).
  PeriodLogStats stats() const;
  const std::string& path() const { return config_.path; }
  // Records in the ring not yet taken by the writer.
  std::uint64_t backlog() const {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }
  std::uint32_t capacity() const { return static_cast<std::uint32_t>(mask_ + 1); }

 private:
  // The tests' seam (defined in the tests only): pauses the writer, which then drains nothing
  // (the ring fills up, then drops) until Stop.
  friend struct PeriodLogTestAccess;

  void WriterMain();
  void Fail(const std::string& why);  // writer thread: stop logging, say so once
  bool OpenFile();                    // writer thread (and Start): PATH + header
  bool ShiftFiles();
  bool Rotate();
  bool WriteAll(const std::string& bytes);
  void WriteBlock();

  LogConfig config_;
  std::int64_t period_ns_ = 0;
  std::string source_;
  std::vector<runlog::Field> fields_;
  std::uint32_t record_bytes_ = 0;

  // Ring: producer owns head_, consumer owns tail_.
  std::unique_ptr<PeriodRecord[]> ring_;
  std::uint64_t mask_ = 0;
  alignas(64) std::atomic<std::uint64_t> head_{0};
  std::uint64_t tail_cache_ = 0;  // producer's last view of tail_
  std::atomic<std::uint64_t> dropped_{0};
  alignas(64) std::atomic<std::uint64_t> tail_{0};

  // Writer state.
  std::thread writer_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> paused_{false};
  std::atomic<bool> running_{false};
  std::vector<std::uint8_t> pending_;  // encoded records of the block being filled
  std::uint32_t pending_count_ = 0;
  std::string block_;
  int fd_ = -1;
  bool rotatable_ = false;  // the open file is a regular file (max_bytes/files apply)
  std::uint64_t file_bytes_ = 0;
  std::uint64_t header_bytes_ = 0;
  bool writing_ = false;  // the writer thread runs (set before the loop starts)
  std::uint32_t sequence_ = 0;
  std::uint32_t file_index_ = 0;
  std::atomic<std::uint64_t> written_{0};
  std::atomic<std::uint64_t> lost_{0};
  std::atomic<std::uint64_t> blocks_{0};
  std::atomic<std::uint64_t> bytes_{0};
  std::atomic<std::uint32_t> files_{0};
  std::atomic<bool> failed_{false};
  std::string error_;  // set before failed_ (release)
};

}  // namespace mrd::firmware::platform
