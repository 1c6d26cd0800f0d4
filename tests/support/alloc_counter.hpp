#pragma once
// Counting replacements of the global operator new/delete and (outside sanitizer builds)
// glibc's malloc family, and two guards:
//   AllocationGuard: counts the allocations made (by any thread) while it is alive;
//   ThreadAllocationGuard: counts them per thread (kernel thread id) while it is alive and
//     keeps the thread, its name and the call stack of the first kKeptAllocations, so a test
//     asserts on the threads that must not allocate (a loop's, a device worker's) and says
//     which thread allocated where when one does.
// test::NotCounted marks a scope of the calling thread whose allocations are none of the
// ThreadAllocationGuard's threads' (a test driving a simulated peer from its loop's thread).
// Include in exactly ONE translation unit of a test executable of its own: it replaces the
// allocator of the whole program.

#include <dirent.h>
#include <execinfo.h>
#include <sys/prctl.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <set>
#include <string>

namespace {
std::atomic<std::uint64_t> g_allocations{0};

// Per-thread attribution (ThreadAllocationGuard). Fixed tables: the hook allocates nothing.
constexpr int kAllocThreads = 64;    // distinct threads counted per guard
constexpr int kKeptAllocations = 8;  // allocations kept with their thread and stack
constexpr int kKeptFrames = 24;
constexpr pid_t kNotCounted = -1;  // the pseudo thread of NotCounted scopes
struct AllocThread {
  std::atomic<pid_t> tid{0};
  std::atomic<std::uint64_t> count{0};
};
struct KeptAllocation {
  pid_t tid = 0;
  char name[16] = {};
  int frames = 0;
  void* stack[kKeptFrames] = {};
};
std::atomic<bool> g_attributing{false};
AllocThread g_alloc_threads[kAllocThreads];
std::atomic<std::uint64_t> g_alloc_unplaced{0};  // threads beyond the table
KeptAllocation g_kept[kKeptAllocations];
std::atomic<int> g_kept_next{0};
thread_local pid_t t_alloc_tid = 0;
thread_local int t_not_counted = 0;
thread_local bool t_in_attribution = false;  // backtrace() may allocate on its first call

void AttributeAllocation() {
  if (!g_attributing.load(std::memory_order_relaxed) || t_in_attribution) return;
  t_in_attribution = true;
  if (t_alloc_tid == 0) t_alloc_tid = gettid();
  const pid_t tid = t_not_counted > 0 ? kNotCounted : t_alloc_tid;
  bool placed = false;
  for (auto& slot : g_alloc_threads) {
    pid_t seen = slot.tid.load(std::memory_order_acquire);
    if (seen == 0 && slot.tid.compare_exchange_strong(seen, tid)) seen = tid;
    if (seen == tid) {
      slot.count.fetch_add(1, std::memory_order_relaxed);
      placed = true;
      break;
    }
  }
  if (!placed) g_alloc_unplaced.fetch_add(1, std::memory_order_relaxed);
  const int k = g_kept_next.fetch_add(1, std::memory_order_relaxed);
  if (k < kKeptAllocations) {
    KeptAllocation& kept = g_kept[k];
    kept.tid = tid;
    prctl(PR_GET_NAME, kept.name);
    kept.frames = backtrace(kept.stack, kKeptFrames);
  }
  t_in_attribution = false;
}

void CountAllocation() {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  AttributeAllocation();
}
}  // namespace

#if defined(__SANITIZE_ADDRESS__)
#define MRD_HOOK_MALLOC 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MRD_HOOK_MALLOC 0
#endif
#endif
#ifndef MRD_HOOK_MALLOC
#define MRD_HOOK_MALLOC 1
#endif

#if MRD_HOOK_MALLOC
extern "C" {
void* __libc_malloc(std::size_t);  // NOLINT: glibc
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* malloc(std::size_t n) {
  CountAllocation();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t m) {
  CountAllocation();
  return __libc_calloc(n, m);
}
void* realloc(void* p, std::size_t n) {
  CountAllocation();
  return __libc_realloc(p, n);
}
}
#endif

void* operator new(std::size_t n) {
  CountAllocation();
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  CountAllocation();
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
// GCC 12 takes these free() calls, once inlined after a counting new, for a mismatch: a false
// positive (the counting new allocates with malloc).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace mrd::test {

// Counts heap allocations (any thread) made while it is alive.
class AllocationGuard {
 public:
  AllocationGuard() : start_(g_allocations.load()) {}
  std::uint64_t count() const { return g_allocations.load() - start_; }

 private:
  std::uint64_t start_;
};

// The calling thread's allocations in this scope count as none of its own (see the top).
class NotCounted {
 public:
  NotCounted() { ++t_not_counted; }
  ~NotCounted() { --t_not_counted; }
  NotCounted(const NotCounted&) = delete;
  NotCounted& operator=(const NotCounted&) = delete;
};

// The kernel thread ids of this process now (/proc/self/task); call it outside any guard.
inline std::set<pid_t> ProcessThreads() {
  std::set<pid_t> out;
  if (DIR* d = opendir("/proc/self/task")) {
    while (const dirent* e = readdir(d)) {
      if (e->d_name[0] != '.') out.insert(static_cast<pid_t>(std::atoi(e->d_name)));
    }
    closedir(d);
  }
  return out;
}

// Counts heap allocations per thread while it is alive (one at a time).
class ThreadAllocationGuard {
 public:
  ThreadAllocationGuard() {
    void* warm[2];
    (void)backtrace(warm, 2);  // loads the unwinder now, not inside a counted allocation
    for (auto& slot : g_alloc_threads) {
      slot.tid.store(0);
      slot.count.store(0);
    }
    g_alloc_unplaced.store(0);
    g_kept_next.store(0);
    g_attributing.store(true);
  }
  ~ThreadAllocationGuard() { Stop(); }
  ThreadAllocationGuard(const ThreadAllocationGuard&) = delete;
  ThreadAllocationGuard& operator=(const ThreadAllocationGuard&) = delete;

  // Ends the counting (the destructor does too); the counts stay readable.
  void Stop() { g_attributing.store(false); }

  // Allocations made by thread `tid` (gettid()) while counting.
  std::uint64_t CountOn(pid_t tid) const {
    for (const auto& slot : g_alloc_threads) {
      if (slot.tid.load() == tid) return slot.count.load();
    }
    return 0;
  }
  // Allocations of every thread, NotCounted scopes included.
  std::uint64_t Total() const {
    std::uint64_t n = g_alloc_unplaced.load();
    for (const auto& slot : g_alloc_threads) n += slot.count.load();
    return n;
  }
  // Per thread: its id and count; then the kept allocations' thread, name and call stack
  // (binary(+offset) [address]: `addr2line -Cfe BINARY OFFSET` names the line). Call after Stop.
  std::string Report() const {
    // Appends only: GCC 12 at -O3 on armhf takes `"text" + std::string` chains for an
    // overlapping memcpy (a false -Wrestrict, bug 105329).
    std::string out;
    for (const auto& slot : g_alloc_threads) {
      const pid_t tid = slot.tid.load();
      if (tid == 0) continue;
      out += "  thread ";
      out += tid == kNotCounted ? std::string("(not counted)") : std::to_string(tid);
      out += ": ";
      out += std::to_string(slot.count.load());
      out += " allocation(s)\n";
    }
    const int kept = std::min(g_kept_next.load(), kKeptAllocations);
    for (int k = 0; k < kept; ++k) {
      const KeptAllocation& a = g_kept[k];
      out += "  allocation ";
      out += std::to_string(k + 1);
      out += " on thread ";
      out += std::to_string(a.tid);
      out += " '";
      out.append(a.name, strnlen(a.name, sizeof a.name));
      out += "':\n";
      if (char** names = backtrace_symbols(a.stack, a.frames)) {
        for (int f = 0; f < a.frames; ++f) {
          out += "    ";
          out += names[f];
          out += "\n";
        }
        std::free(names);
      }
    }
    return out;
  }
};

}  // namespace mrd::test
