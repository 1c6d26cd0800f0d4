#pragma once
// A single-writer seqlock over a trivially copyable value, stored as relaxed atomic words so
// readers never race: the hand-over between a real-time loop and other threads (telemetry
// out of the loop, bus samples from an I/O thread into it) without locks or allocation.

#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

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

}  // namespace mrd::firmware
