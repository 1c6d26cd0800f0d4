#include "sem/engine/kernels.hpp"

#include <atomic>
#include <cstring>

// The kernels at 4 doubles per vector: an AVX2 clone chosen at load time when the CPU has it
// (no FMA: the results stay the same), SSE2 pairs otherwise. Clang (14) has no target_clones
// on templates: one SSE2 version there.
#if defined(__x86_64__) && !defined(__clang__)
#define MRD_MULTIVERSION __attribute__((target_clones("avx2", "default")))
#else
#define MRD_MULTIVERSION
#endif
#define MRD_KERNEL_W 4
#define MRD_KERNEL_NS w4
#include "sem/engine/kernels_impl.inc"
#undef MRD_KERNEL_NS
#undef MRD_KERNEL_W

namespace mrd::host::internal {
namespace {

// 8 where this build has the AVX-512 kernels and the CPU (and OS) has AVX-512F, else 4.
std::size_t WidestLaneWidth() {
#if MRD_SEM_AVX512
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") ? 8 : 4;
#else
  return 4;
#endif
}

std::atomic<std::size_t>& Width() {
  static std::atomic<std::size_t> w{WidestLaneWidth()};
  return w;
}

// The kernels of the width in use.
const KernelSet& Kernels() {
#if MRD_SEM_AVX512
  if (Width().load(std::memory_order_relaxed) == 8) return w8::kKernels;
#endif
  return w4::kKernels;
}

// out = the product of the columns (Product in kernels.hpp); one width: it is not a lane kernel.
MRD_MULTIVERSION void ProductT(const double* const* cols, std::size_t n, std::size_t off,
                               std::size_t len, double* out) {
  if (n == 0) {
    for (std::size_t i = 0; i < len; ++i) out[i] = 1.0;
    return;
  }
  const double* a = cols[0] + off;
  if (n == 1) {
    for (std::size_t i = 0; i < len; ++i) out[i] = a[i];
    return;
  }
  const double* b = cols[1] + off;
  if (n == 2) {
    for (std::size_t i = 0; i < len; ++i) out[i] = a[i] * b[i];
    return;
  }
  const double* d = cols[2] + off;
  for (std::size_t i = 0; i < len; ++i) out[i] = a[i] * b[i] * d[i];
  for (std::size_t f = 3; f < n; ++f) {
    const double* e = cols[f] + off;
    for (std::size_t i = 0; i < len; ++i) out[i] *= e[i];
  }
}

#undef MRD_MULTIVERSION

}  // namespace

std::size_t LaneWidth() { return Width().load(std::memory_order_relaxed); }

bool SetLaneWidth(std::size_t w) {
  const std::size_t widest = WidestLaneWidth();
  if (w == 0) w = widest;
  if (w != 4 && w != widest) return false;
  Width().store(w, std::memory_order_relaxed);
  return true;
}

// One lane group is nv vectors of LaneWidth() lanes.
void LaneSums(int nv, const double* const* u, std::size_t off, const double* theta, std::size_t m,
              std::size_t len, double* c) {
  Kernels().lane_sums(nv, u, off, theta, m, len, c);
}

void LaneFreeRun(int nv, std::size_t nq, const double* c, std::size_t stride, const double* y,
                 const double* w, std::size_t len, double lim, double* p, double* acc, bool* bad) {
  Kernels().lane_free_run(nv, nq, c, stride, y, w, len, lim, p, acc, bad);
}

void LaneExtra(int nv, const double* const* f, std::size_t nf, std::size_t off, const double* th,
               const int* q, std::size_t nq, const char* fresh, std::size_t len, double* c,
               std::size_t c_stride) {
  Kernels().lane_extra(nv, f, nf, off, th, q, nq, fresh, len, c, c_stride);
}

void LaneGram(int nv, const double* const* f, std::size_t nf, std::size_t off, const double* x,
              std::size_t len, double* acc) {
  Kernels().lane_gram(nv, f, nf, off, x, len, acc);
}

void Product(const double* const* cols, std::size_t n, std::size_t off, std::size_t len,
             double* out) {
  ProductT(cols, n, off, len, out);
}

}  // namespace mrd::host::internal
