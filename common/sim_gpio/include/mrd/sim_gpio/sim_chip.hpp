#pragma once
// A simulated GPIO chip in a file shared by processes (mmap, MAP_SHARED): kNumLines lines,
// each with its level and a ring of its last kRingSize edge events (CLOCK_MONOTONIC
// timestamp [ns], rising/falling, sequence number). Stands in for a GPIO character device
// (libgpiod) in tests and in the HIL harness: the firmware drives its outputs (enable,
// heartbeat) and reads its inputs (fault line, encoder A/B) here; the harness the other way.
//
// Concurrency: one writer per line (whoever drives it), any number of readers, lock-free.
// Each event slot is a small seqlock (its sequence number is cleared while it is written), so
// a reader that is overtaken by the writer sees a torn or overwritten slot as lost, never as a
// wrong event. The layout holds only lock-free 64-bit atomics (address-free, so valid across
// processes).
//
// Lifecycle: the harness (or a test peer) creates the file (Open with create): a new chip is
// initialised under a temporary name and renamed into place, so a reader never sees it
// half-made; an existing valid chip is reused (a restarted peer continues its rings). The
// firmware opens an existing chip only. Open and Close allocate and may block; everything
// else is real-time safe (no allocation; no system call but Check's one fstat).
//
// A damaged file: the file may be truncated while mapped (a test, a slip of the hand), and an
// access beyond its new end would raise SIGBUS. Check() (one fstat and the magic) tells
// before an access; the accessors of a chip found damaged fail (SetValue false) or read zeros.
// For a truncation between a Check and an access, Open installs a SIGBUS handler once per
// process: a fault inside a chip's mapping replaces that mapping with zero pages and marks the
// chip damaged, and the access goes on; a SIGBUS anywhere else takes its usual course.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>

namespace mrd::sim_gpio {

inline constexpr std::size_t kNumLines = 64;
inline constexpr std::size_t kRingSize = 256;                   // events kept per line
inline constexpr std::uint64_t kMagic = 0x4f4950474d49534dULL;  // "MSIMGPIO"
inline constexpr std::uint32_t kVersion = 1;

struct Event {
  std::uint64_t seq = 0;  // 1, 2, ... per line (0: none)
  std::int64_t t_ns = 0;  // CLOCK_MONOTONIC of the edge [ns]
  bool rising = false;
};

// The shared layout (the file holds exactly one of these).
struct EventSlot {
  std::atomic<std::uint64_t> seq;  // seq of the event in the slot; 0 while being written
  std::atomic<std::int64_t> t_ns;
  std::atomic<std::uint64_t> rising;
};
struct LineState {
  std::atomic<std::uint64_t> value;  // 0 / 1
  std::atomic<std::uint64_t> head;   // events written so far
  EventSlot ring[kRingSize];
};
struct Layout {
  std::atomic<std::uint64_t> magic;  // kMagic once initialised
  std::atomic<std::uint64_t> version;
  std::atomic<std::uint64_t> num_lines;
  std::atomic<std::uint64_t> ring_size;
  LineState lines[kNumLines];
};
static_assert(std::atomic<std::uint64_t>::is_always_lock_free);

class SimChip {
 public:
  SimChip() = default;
  ~SimChip() { Close(); }
  SimChip(const SimChip&) = delete;
  SimChip& operator=(const SimChip&) = delete;

  // Maps the chip at path. create: make it when missing (reuse a valid one). false with
  // *error ("sim chip PATH: reason") when it cannot be opened, is not a chip, or has another
  // layout version.
  bool Open(const std::string& path, bool create, std::string* error);
  void Close();
  bool is_open() const { return layout_ != nullptr; }
  // True while the file still holds this chip (size unchanged, magic intact). Once false the
  // chip is damaged for good (reopen it): its mapping is replaced by zero pages, SetValue
  // fails, GetValue, head and ReadEvents read nothing. Real-time safe: one fstat.
  bool Check();
  // The chip was found damaged (by Check or by the SIGBUS handler). No system call.
  bool damaged() const;
  const std::string& path() const { return path_; }

  // Writer of `line` (one per line): sets its level; a change records an edge at t_ns.
  // Lines >= kNumLines are ignored (false).
  bool SetValue(std::size_t line, bool value, std::int64_t t_ns);
  // Current level (false for lines >= kNumLines).
  bool GetValue(std::size_t line) const;
  // Events written on the line so far (a reader's cursor starts here to see only new ones).
  std::uint64_t head(std::size_t line) const;
  // Events after *cursor (oldest first, at most max) into out; advances *cursor. *lost counts
  // the events that the writer overwrote before they were read (the ring holds kRingSize).
  std::size_t ReadEvents(std::size_t line, std::uint64_t* cursor, Event* out, std::size_t max,
                         std::uint64_t* lost) const;

 private:
  void MarkDamaged();

  Layout* layout_ = nullptr;
  int fd_ = -1;    // kept open for Check's fstat
  int slot_ = -1;  // entry in the process's table of mapped chips (SIGBUS handler)
  std::string path_;
};

}  // namespace mrd::sim_gpio
