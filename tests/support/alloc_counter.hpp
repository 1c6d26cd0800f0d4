#pragma once
// Counting replacements of the global operator new/delete and (outside sanitizer builds)
// glibc's malloc family, and AllocationGuard, which counts the allocations made (by any
// thread) while it is alive. Include in exactly ONE translation unit of a test executable
// of its own: it replaces the allocator of the whole program.

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <new>

namespace {
std::atomic<std::uint64_t> g_allocations{0};
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
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t m) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(n, m);
}
void* realloc(void* p, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, n);
}
}
#endif

void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace mrd::test {

// Counts heap allocations (any thread) made while it is alive.
class AllocationGuard {
 public:
  AllocationGuard() : start_(g_allocations.load()) {}
  std::uint64_t count() const { return g_allocations.load() - start_; }

 private:
  std::uint64_t start_;
};

}  // namespace mrd::test
