#pragma once
// Telemetry out of the real-time loop without locks or allocation: a single-writer seqlock
// over a trivially copyable snapshot (stored as relaxed atomic words, so readers never race).
// The loop publishes a snapshot every period (wait-free); any thread reads the latest one.

#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {

template <typename T>
class Seqlock {
  static_assert(std::is_trivially_copyable_v<T>);
  static constexpr std::size_t kWords = (sizeof(T) + 7) / 8;

 public:
  // Single writer. Wait-free, real-time safe.
  void Write(const T& value) {
    std::array<std::uint64_t, kWords> buf{};
    std::memcpy(buf.data(), &value, sizeof(T));
    const std::uint64_t s = seq_.load(std::memory_order_relaxed);
    seq_.store(s + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    for (std::size_t i = 0; i < kWords; ++i) words_[i].store(buf[i], std::memory_order_relaxed);
    seq_.store(s + 2, std::memory_order_release);
  }
  // One attempt; false when a write was in progress (try again).
  bool TryRead(T* out) const {
    const std::uint64_t s0 = seq_.load(std::memory_order_acquire);
    if ((s0 & 1U) != 0) return false;
    std::array<std::uint64_t, kWords> buf{};
    for (std::size_t i = 0; i < kWords; ++i) buf[i] = words_[i].load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (seq_.load(std::memory_order_relaxed) != s0) return false;
    std::memcpy(static_cast<void*>(out), buf.data(), sizeof(T));
    return true;
  }
  // Latest complete snapshot (spins while the writer is mid-write).
  T Read() const {
    T out{};
    while (!TryRead(&out)) {
    }
    return out;
  }
  std::uint64_t version() const { return seq_.load(std::memory_order_acquire) / 2; }

 private:
  std::atomic<std::uint64_t> seq_{0};
  std::array<std::atomic<std::uint64_t>, kWords> words_{};
};

struct TelemetrySnapshot {
  std::uint64_t ticks = 0;
  std::uint64_t overruns = 0;           // periods whose work ended past the next deadline
  std::uint64_t missed_periods = 0;     // deadlines skipped after overruns
  std::int64_t worst_latency_ns = 0;    // wake-up minus deadline, worst
  std::int64_t worst_exec_ns = 0;       // work per period, worst
  std::int64_t last_exec_ns = 0;
  std::uint64_t read_faults = 0;
  std::uint64_t write_faults = 0;
  std::uint64_t unreachable = 0;        // force demands saturated by the inverter
  std::uint64_t model_resets = 0;
  WatchdogCounters watchdog;
  std::uint32_t active_causes = 0;
  bool safe = true;
  double last_command_v = 0.0;
  double model_force_n = 0.0;
  double force_demand_n = 0.0;
  double measured_force_n = 0.0;        // NaN when no force sensor
  // Sums for RMS figures over periods with a measured force (not in the safe state).
  std::uint64_t force_samples = 0;
  double sum_sq_model_error = 0.0;      // (model - measured)^2 [N^2]
  std::uint64_t tracking_samples = 0;
  double sum_sq_tracking_error = 0.0;   // (demand - measured)^2 [N^2], force laws
};

using Telemetry = Seqlock<TelemetrySnapshot>;

}  // namespace mrd::firmware
