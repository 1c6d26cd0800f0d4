#include "mrd/firmware/platform/period_log.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <bit>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <limits>

namespace mrd::firmware::platform {
namespace {

using runlog::Type;

std::uint64_t Bits(double v) { return std::bit_cast<std::uint64_t>(v); }
std::uint64_t Signed(std::int64_t v) { return static_cast<std::uint64_t>(v); }

// Age of a sample at the period's time [ns]; -1 when never sampled.
std::int64_t Age(const Stamped& s, std::int64_t t_ns) {
  return s.stamp_ns == std::numeric_limits<std::int64_t>::min() ? -1 : t_ns - s.stamp_ns;
}

struct FieldDef {
  const char* name;
  Type type;
  const char* unit;
  std::uint64_t (*get)(const PeriodRecord&);  // value bits (f64: IEEE 754 bits)
};

// The file's field table: one line per field, in record order (docs/logging.md lists it).
constexpr FieldDef kFields[] = {
    {"period", Type::kU64, "", [](const PeriodRecord& r) { return r.period; }},
    {"t_ns", Type::kI64, "ns", [](const PeriodRecord& r) { return Signed(r.t_ns); }},
    {"latency_ns", Type::kI64, "ns", [](const PeriodRecord& r) { return Signed(r.latency_ns); }},
    {"exec_ns", Type::kI64, "ns", [](const PeriodRecord& r) { return Signed(r.exec_ns); }},
    {"v", Type::kF64, "cm/s",
     [](const PeriodRecord& r) { return Bits(r.frame[Input::kVelocity].value); }},
    {"v_age_ns", Type::kI64, "ns",
     [](const PeriodRecord& r) { return Signed(Age(r.frame[Input::kVelocity], r.t_ns)); }},
    {"x", Type::kF64, "cm",
     [](const PeriodRecord& r) { return Bits(r.frame[Input::kDisplacement].value); }},
    {"x_age_ns", Type::kI64, "ns",
     [](const PeriodRecord& r) { return Signed(Age(r.frame[Input::kDisplacement], r.t_ns)); }},
    {"demand", Type::kF64, "N",
     [](const PeriodRecord& r) { return Bits(r.frame[Input::kDemand].value); }},
    {"demand_age_ns", Type::kI64, "ns",
     [](const PeriodRecord& r) { return Signed(Age(r.frame[Input::kDemand], r.t_ns)); }},
    {"body_v", Type::kF64, "cm/s",
     [](const PeriodRecord& r) { return Bits(r.frame[Input::kBodyVelocity].value); }},
    {"body_v_age_ns", Type::kI64, "ns",
     [](const PeriodRecord& r) { return Signed(Age(r.frame[Input::kBodyVelocity], r.t_ns)); }},
    {"force", Type::kF64, "N",
     [](const PeriodRecord& r) { return Bits(r.frame[Input::kForce].value); }},
    {"force_age_ns", Type::kI64, "ns",
     [](const PeriodRecord& r) { return Signed(Age(r.frame[Input::kForce], r.t_ns)); }},
    {"fault_line", Type::kU8, "",
     [](const PeriodRecord& r) { return std::uint64_t{r.frame.fault_line ? 1U : 0U}; }},
    {"bus_faults", Type::kU32, "",
     [](const PeriodRecord& r) { return std::uint64_t{r.frame.bus_faults}; }},
    {"read_status", Type::kU8, "",
     [](const PeriodRecord& r) { return static_cast<std::uint64_t>(r.read); }},
    {"write_status", Type::kU8, "",
     [](const PeriodRecord& r) { return static_cast<std::uint64_t>(r.write); }},
    {"v_used", Type::kF64, "cm/s", [](const PeriodRecord& r) { return Bits(r.v_used); }},
    {"x_used", Type::kF64, "cm", [](const PeriodRecord& r) { return Bits(r.x_used); }},
    {"model_force", Type::kF64, "N", [](const PeriodRecord& r) { return Bits(r.model_force); }},
    {"force_demand", Type::kF64, "N", [](const PeriodRecord& r) { return Bits(r.force_demand); }},
    {"e_law", Type::kF64, "V", [](const PeriodRecord& r) { return Bits(r.e_law); }},
    {"command", Type::kF64, "V", [](const PeriodRecord& r) { return Bits(r.command_v); }},
    {"force_law", Type::kU8, "",
     [](const PeriodRecord& r) { return std::uint64_t{r.force_law ? 1U : 0U}; }},
    {"reachable", Type::kU8, "",
     [](const PeriodRecord& r) { return std::uint64_t{r.reachable ? 1U : 0U}; }},
    {"safe", Type::kU8, "", [](const PeriodRecord& r) { return std::uint64_t{r.safe ? 1U : 0U}; }},
    {"causes", Type::kU32, "", [](const PeriodRecord& r) { return std::uint64_t{r.causes}; }},
    {"param_version", Type::kU32, "",
     [](const PeriodRecord& r) { return std::uint64_t{r.param_version}; }},
    {"passive", Type::kU8, "",
     [](const PeriodRecord& r) { return std::uint64_t{r.passive ? 1U : 0U}; }},
    {"non_monotone", Type::kU8, "",
     [](const PeriodRecord& r) { return std::uint64_t{r.non_monotone ? 1U : 0U}; }},
};

std::uint64_t RoundUpPow2(std::uint64_t n) {
  std::uint64_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

// A regular file at path that holds something other than an mrd log (its first bytes are not
// the runlog magic): a config, a table, anyone's data. Empty files and logs are fair game.
bool ForeignFile(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_size == 0) return false;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return true;  // unreadable: not known to be a log
  char head[sizeof runlog::kMagic] = {};
  const ssize_t n = ::read(fd, head, sizeof head);
  ::close(fd);
  return n != static_cast<ssize_t>(sizeof head) ||
         std::memcmp(head, runlog::kMagic, sizeof head) != 0;
}

// Longest wait for a FIFO's reader to take a block [ms] (a reader that does not read must
// neither block the writer nor the firmware's exit).
constexpr int kFifoWaitMs = 200;

}  // namespace

std::string CheckLogPath(const LogConfig& config) {
  if (!config.enabled || config.path.empty()) return "";
  struct stat st {};
  if (::stat(config.path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    return "log " + config.path + ": is a directory (give a file name)";
  }
  // The log truncates PATH and rotates PATH.1 .. PATH.<files-1>: none may be another file.
  const std::uint32_t files = config.files == 0 ? 1 : config.files;
  for (std::uint32_t k = 0; k < files; ++k) {
    const std::string p = k == 0 ? config.path : config.path + "." + std::to_string(k);
    if (ForeignFile(p)) {
      return "log " + config.path + ": " + p +
             " exists and is not an mrd log (a configuration? a table?): the log would " +
             (k == 0 ? "overwrite or move" : "replace") + " it; give another path";
    }
  }
  return "";
}

std::vector<runlog::Field> PeriodLogFields() {
  std::vector<runlog::Field> f;
  for (const FieldDef& d : kFields) f.push_back({d.name, d.type, d.unit});
  return f;
}

void EncodePeriodRecord(const PeriodRecord& r, std::uint8_t* out) {
  for (const FieldDef& d : kFields) {
    const std::uint64_t v = d.get(r);
    switch (d.type) {
      case Type::kU8:
        runlog::PutU8(out, static_cast<std::uint8_t>(v));
        break;
      case Type::kU32:
        runlog::PutU32(out, static_cast<std::uint32_t>(v));
        break;
      case Type::kU64:
      case Type::kI64:
      case Type::kF64:
        runlog::PutU64(out, v);
        break;
    }
    out += runlog::TypeSize(d.type);
  }
}

PeriodLog::~PeriodLog() { Stop(); }

void PeriodLog::Start(const LogConfig& config, std::int64_t period_ns, const std::string& source) {
  config_ = config;
  if (config_.block_records == 0) config_.block_records = 1;
  if (config_.files == 0) config_.files = 1;
  period_ns_ = period_ns;
  source_ = source;
  fields_ = PeriodLogFields();
  runlog::Header h;
  h.fields = fields_;
  record_bytes_ = h.record_bytes();
  const std::uint64_t capacity = RoundUpPow2(config_.ring_records < 2 ? 2 : config_.ring_records);
  mask_ = capacity - 1;
  ring_ = std::make_unique<PeriodRecord[]>(
      static_cast<std::size_t>(capacity));  // value-initialised: every page touched
  for (std::uint64_t i = 0; i < capacity; ++i)
    ring_[static_cast<std::size_t>(i)].period = i;  // and written
  pending_.assign(static_cast<std::size_t>(config_.block_records) * record_bytes_, 0);
  block_.reserve(runlog::kBlockHeaderBytes + pending_.size());
  // A log from an earlier start (a restart after a crash) is kept as PATH.1 (a regular file
  // only: /dev/null or a FIFO stays where it is).
  if (const std::string why = CheckLogPath(config_); !why.empty()) {  // main refuses it first
    Fail(why.substr(why.find(": ") + 2));
    return;
  }
  struct stat st {};
  if (config_.files > 1 && ::stat(config_.path.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
      st.st_size > 0 && !ShiftFiles()) {
    return;
  }
  if (!OpenFile()) return;
  writing_ = true;
  running_.store(true);
  writer_ = std::thread([this] { WriterMain(); });
}

void PeriodLog::OnPeriod(const PeriodRecord& record) {
  if (!writing_) {  // the file could not be opened: nothing drains the ring
    lost_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const std::uint64_t h = head_.load(std::memory_order_relaxed);
  if (h - tail_cache_ > mask_) {
    tail_cache_ = tail_.load(std::memory_order_acquire);
    if (h - tail_cache_ > mask_) {
      dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      return;
    }
  }
  ring_[static_cast<std::size_t>(h & mask_)] = record;
  head_.store(h + 1, std::memory_order_release);
}

void PeriodLog::Fail(const std::string& why) {
  if (failed_.load(std::memory_order_relaxed)) return;
  error_ = why;
  failed_.store(true, std::memory_order_release);
  std::fprintf(stderr, "warning: log %s: %s; logging stopped (the loop keeps running)\n",
               config_.path.c_str(), why.c_str());
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool PeriodLog::OpenFile() {
  // Non-blocking: a FIFO without a reader fails at once (ENXIO) instead of blocking the
  // start-up, and one whose reader stops reading cannot block the writer (WriteAll).
  fd_ = ::open(config_.path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NONBLOCK, 0644);
  if (fd_ < 0) {
    Fail(errno == ENXIO ? std::string("a FIFO with no reader")
                        : std::string("cannot create the file (") + std::strerror(errno) + ")");
    return false;
  }
  files_.fetch_add(1, std::memory_order_relaxed);
  file_bytes_ = 0;
  // Only a regular file is rotated: renaming a device (/dev/null), FIFO or socket path would
  // replace the node itself with a log file.
  struct stat st {};
  rotatable_ = ::fstat(fd_, &st) == 0 && S_ISREG(st.st_mode);
  runlog::Header h;
  h.file_index = file_index_;
  h.period_ns = period_ns_;
  h.source = source_;
  h.fields = fields_;
  const std::string header = runlog::EncodeHeader(h);
  header_bytes_ = header.size();
  return WriteAll(header);
}

bool PeriodLog::WriteAll(const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno == EAGAIN) {  // a FIFO (or device) that is full: wait a little
      pollfd p{fd_, POLLOUT, 0};
      if (::poll(&p, 1, kFifoWaitMs) > 0 && (p.revents & POLLOUT) != 0) continue;
      Fail("the reader does not keep up (nothing taken for " + std::to_string(kFifoWaitMs) +
           " ms)");
      return false;
    }
    if (n <= 0) {
      Fail(std::string("write failed (") + (n < 0 ? std::strerror(errno) : "nothing written") +
           ")");
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  file_bytes_ += bytes.size();
  bytes_.fetch_add(bytes.size(), std::memory_order_relaxed);
  return true;
}

// PATH.<files-2> -> PATH.<files-1>, ..., PATH -> PATH.1 (files = 1: nothing; the new PATH
// replaces the old). false (and the log failed) when a rename fails.
bool PeriodLog::ShiftFiles() {
  for (std::uint32_t k = config_.files - 1; k >= 1; --k) {
    const std::string from = k == 1 ? config_.path : config_.path + "." + std::to_string(k - 1);
    const std::string to = config_.path + "." + std::to_string(k);
    if (::rename(from.c_str(), to.c_str()) != 0 && errno != ENOENT) {
      Fail("cannot rotate " + from + " to " + to + " (" + std::strerror(errno) + ")");
      return false;
    }
  }
  return true;
}

// The current file is full: shift the files, start a new PATH.
bool PeriodLog::Rotate() {
  if (::close(fd_) != 0) {
    fd_ = -1;
    Fail(std::string("close failed (") + std::strerror(errno) + ")");
    return false;
  }
  fd_ = -1;
  if (!ShiftFiles()) return false;
  ++file_index_;
  return OpenFile();
}

void PeriodLog::WriteBlock() {
  if (pending_count_ == 0) return;
  const std::uint32_t count = pending_count_;
  pending_count_ = 0;
  if (failed_.load(std::memory_order_relaxed)) {
    lost_.fetch_add(count, std::memory_order_relaxed);
    return;
  }
  block_.clear();
  runlog::EncodeBlock(sequence_, dropped_.load(std::memory_order_relaxed), pending_.data(), count,
                      record_bytes_, &block_);
  if (rotatable_ && file_bytes_ + block_.size() > config_.max_bytes &&
      file_bytes_ > header_bytes_ && !Rotate()) {
    lost_.fetch_add(count, std::memory_order_relaxed);
    return;
  }
  if (!WriteAll(block_)) {
    lost_.fetch_add(count, std::memory_order_relaxed);
    return;
  }
  if (config_.sync && ::fdatasync(fd_) != 0 && errno != EINVAL) {
    Fail(std::string("fdatasync failed (") + std::strerror(errno) + ")");
  }
  ++sequence_;
  blocks_.fetch_add(1, std::memory_order_relaxed);
  written_.fetch_add(count, std::memory_order_relaxed);
}

void PeriodLog::WriterMain() {
  using Steady = std::chrono::steady_clock;
  auto last_write = Steady::now();
  const auto flush = std::chrono::nanoseconds(config_.flush_ns);
  const auto poll = std::chrono::milliseconds(5);
  for (;;) {
    const bool stopping = stop_.load(std::memory_order_acquire);
    if (!paused_.load(std::memory_order_acquire) || stopping) {
      std::uint64_t t = tail_.load(std::memory_order_relaxed);
      const std::uint64_t h = head_.load(std::memory_order_acquire);
      while (t != h) {
        EncodePeriodRecord(
            ring_[static_cast<std::size_t>(t & mask_)],
            pending_.data() + static_cast<std::size_t>(pending_count_) * record_bytes_);
        ++t;
        tail_.store(t, std::memory_order_release);
        if (++pending_count_ == config_.block_records) {
          WriteBlock();
          last_write = Steady::now();
        }
      }
      if (pending_count_ > 0 && (stopping || Steady::now() - last_write >= flush)) {
        WriteBlock();
        last_write = Steady::now();
      }
    }
    if (stopping) break;
    std::this_thread::sleep_for(poll);
  }
  if (fd_ >= 0) {
    if (config_.sync) (void)::fdatasync(fd_);
    if (::close(fd_) != 0) Fail(std::string("close failed (") + std::strerror(errno) + ")");
    fd_ = -1;
  }
}

void PeriodLog::Stop() {
  if (running_.exchange(false)) {
    stop_.store(true, std::memory_order_release);
    writer_.join();
  } else if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
}

PeriodLogStats PeriodLog::stats() const {
  PeriodLogStats s;
  const std::uint64_t dropped = dropped_.load(std::memory_order_relaxed);
  s.dropped = dropped;
  s.written = written_.load(std::memory_order_relaxed);
  s.lost = lost_.load(std::memory_order_relaxed);
  s.pushed = head_.load(std::memory_order_acquire) + dropped + (writing_ ? 0 : s.lost);
  s.blocks = blocks_.load(std::memory_order_relaxed);
  s.bytes = bytes_.load(std::memory_order_relaxed);
  s.files = files_.load(std::memory_order_relaxed);
  s.failed = failed_.load(std::memory_order_acquire);
  if (s.failed) s.error = error_;
  return s;
}

}  // namespace mrd::firmware::platform
