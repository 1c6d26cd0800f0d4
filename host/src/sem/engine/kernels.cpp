#include "sem/engine/kernels.hpp"

#include <cstring>

namespace mrd::host::internal {
namespace {

// kLaneWidth doubles (GCC/Clang vector extension; SSE2 pairs without AVX).
using Vec = double __attribute__((vector_size(kLaneWidth * sizeof(double))));
using Mask = long long __attribute__((vector_size(kLaneWidth * sizeof(double))));
// The same vector at any double's address (as __m256d_u); functions taking or returning Vec
// would change with the ABI of the clone, so loads and stores are macros.
typedef double VecU
    __attribute__((vector_size(kLaneWidth * sizeof(double)), aligned(8), may_alias));
#define Load(p) (*reinterpret_cast<const VecU*>(p))
#define Store(p, v) (*reinterpret_cast<VecU*>(p) = (v))

#if defined(__clang__)
#define Shuffle(a, b, i0, i1, i2, i3) __builtin_shufflevector(a, b, i0, i1, i2, i3)
#else
#define Shuffle(a, b, i0, i1, i2, i3) __builtin_shuffle(a, b, Mask{i0, i1, i2, i3})
#endif

// AVX2 clone chosen at load time when the CPU has it (no FMA: the results stay the same).
// Clang (14) has no target_clones on templates: one SSE2 version there.
#if defined(__x86_64__) && !defined(__clang__)
#define MRD_MULTIVERSION __attribute__((target_clones("avx2", "default")))
#else
#define MRD_MULTIVERSION
#endif

// One or two lane vectors (W) from lane vector v: c (+)= the terms [j, j + 4) or the term j.
template <int W>
__attribute__((always_inline)) inline void AddFour(const double* const* u, std::size_t off,
                                                   const double* theta, std::size_t j,
                                                   std::size_t kL, std::size_t lv, std::size_t len,
                                                   bool first, double* c) {
  const double *a0 = u[j] + off, *a1 = u[j + 1] + off, *a2 = u[j + 2] + off, *a3 = u[j + 3] + off;
  Vec t0[W], t1[W], t2[W], t3[W];
  for (int w = 0; w < W; ++w) {
    const std::size_t o = lv + static_cast<std::size_t>(w) * kLaneWidth;
    t0[w] = Load(theta + j * kL + o);
    t1[w] = Load(theta + (j + 1) * kL + o);
    t2[w] = Load(theta + (j + 2) * kL + o);
    t3[w] = Load(theta + (j + 3) * kL + o);
  }
  for (std::size_t s = 0; s < len; ++s) {
    for (int w = 0; w < W; ++w) {
      double* cv = c + s * kL + lv + static_cast<std::size_t>(w) * kLaneWidth;
      const Vec g = (t0[w] * a0[s] + t1[w] * a1[s]) + (t2[w] * a2[s] + t3[w] * a3[s]);
      Store(cv, first ? g : Load(cv) + g);
    }
  }
}

template <int W>
__attribute__((always_inline)) inline void AddOne(const double* const* u, std::size_t off,
                                                  const double* theta, std::size_t j,
                                                  std::size_t kL, std::size_t lv, std::size_t len,
                                                  bool first, double* c) {
  const double* a0 = u[j] + off;
  Vec t0[W];
  for (int w = 0; w < W; ++w) {
    t0[w] = Load(theta + j * kL + lv + static_cast<std::size_t>(w) * kLaneWidth);
  }
  for (std::size_t s = 0; s < len; ++s) {
    for (int w = 0; w < W; ++w) {
      double* cv = c + s * kL + lv + static_cast<std::size_t>(w) * kLaneWidth;
      const Vec g = t0[w] * a0[s];
      Store(cv, first ? g : Load(cv) + g);
    }
  }
}

template <int NV>
MRD_MULTIVERSION void LaneSumsT(const double* const* u, std::size_t off, const double* theta,
                                std::size_t m, std::size_t len, double* c) {
  constexpr std::size_t kL = NV * kLaneWidth;
  if (m == 0) {
    std::memset(c, 0, len * kL * sizeof(double));
    return;
  }
  for (int v = 0; v < NV; v += 2) {  // lane vectors in pairs (u loaded once per pair)
    const std::size_t lv = static_cast<std::size_t>(v) * kLaneWidth;
    std::size_t j = 0;
    for (; j + 4 <= m; j += 4) {
      if (v + 1 < NV) {
        AddFour<2>(u, off, theta, j, kL, lv, len, j == 0, c);
      } else {
        AddFour<1>(u, off, theta, j, kL, lv, len, j == 0, c);
      }
    }
    for (; j < m; ++j) {
      if (v + 1 < NV) {
        AddOne<2>(u, off, theta, j, kL, lv, len, j == 0, c);
      } else {
        AddOne<1>(u, off, theta, j, kL, lv, len, j == 0, c);
      }
    }
  }
}

// NQ > 0: nq fixed at compile time; 0: nq at run time.
template <int NV, int NQ>
MRD_MULTIVERSION void LaneFreeRunT(std::size_t nq_rt, const double* c, std::size_t stride,
                                   const double* y, const double* w, std::size_t len, double lim,
                                   double* p, double* acc, bool* bad) {
  constexpr std::size_t kL = NV * kLaneWidth;
  const std::size_t nq = NQ > 0 ? static_cast<std::size_t>(NQ) : nq_rt;
  Vec pv[NV], av[NV];
  Mask bv[NV];
  for (int v = 0; v < NV; ++v) {
    const std::size_t lv = static_cast<std::size_t>(v) * kLaneWidth;
    pv[v] = Load(p + lv);
    av[v] = Load(acc + lv);
    for (std::size_t l = 0; l < kLaneWidth; ++l) bv[v][l] = bad[lv + l] ? -1 : 0;
  }
  for (std::size_t s = 0; s < len; ++s) {
    for (int v = 0; v < NV; ++v) {
      const std::size_t lv = static_cast<std::size_t>(v) * kLaneWidth;
      Vec yk = Load(c + ((nq - 1) * stride + s) * kL + lv);
      for (std::size_t q = nq - 1; q-- > 0;) yk = yk * pv[v] + Load(c + (q * stride + s) * kL + lv);
      const Vec e = y[s] - yk;
      av[v] += w[s] * (e * e);
      // Same verdict as !(|yk| <= lim), NaN included.
      bv[v] |= ~((yk <= lim) & (yk >= -lim));
      pv[v] = yk;
    }
  }
  for (int v = 0; v < NV; ++v) {
    const std::size_t lv = static_cast<std::size_t>(v) * kLaneWidth;
    Store(p + lv, pv[v]);
    Store(acc + lv, av[v]);
    for (std::size_t l = 0; l < kLaneWidth; ++l) bad[lv + l] = bv[v][l] != 0;
  }
}

template <int NV>
void LaneFreeRunNq(std::size_t nq, const double* c, std::size_t stride, const double* y,
                   const double* w, std::size_t len, double lim, double* p, double* acc,
                   bool* bad) {
  switch (nq) {
    case 1:
      return LaneFreeRunT<NV, 1>(nq, c, stride, y, w, len, lim, p, acc, bad);
    case 2:
      return LaneFreeRunT<NV, 2>(nq, c, stride, y, w, len, lim, p, acc, bad);
    case 3:
      return LaneFreeRunT<NV, 3>(nq, c, stride, y, w, len, lim, p, acc, bad);
    default:
      return LaneFreeRunT<NV, 0>(nq, c, stride, y, w, len, lim, p, acc, bad);
  }
}

// NF > 0: nf fixed at compile time; 0: nf at run time.
template <int NV, int NF>
MRD_MULTIVERSION void LaneExtraT(const double* const* f, std::size_t nf_rt, std::size_t off,
                                 const double* th, const int* q, std::size_t nq, const char* fresh,
                                 std::size_t len, double* c, std::size_t c_stride) {
  constexpr std::size_t kL = NV * kLaneWidth;
  const std::size_t nf = NF > 0 ? static_cast<std::size_t>(NF) : nf_rt;
  double xt[kSubBlock * kLaneWidth];  // th * input, [s][lane] of one lane vector
  for (int v = 0; v < NV; ++v) {
    const std::size_t lv = static_cast<std::size_t>(v) * kLaneWidth;
    const double* const* fv = f + lv * nf;  // factors of lane lv + l: fv[l * nf + k]
    const Vec t = Load(th + lv);
    std::size_t s = 0;
    for (; s + 4 <= len; s += 4) {
      Vec y[4];  // y[l]: input of lane l at samples s ... s + 3 (factors in order, as Product)
      for (std::size_t l = 0; l < 4; ++l) {
        Vec x = Load(fv[l * nf] + off + s);
        for (std::size_t k = 1; k < nf; ++k) x = x * Load(fv[l * nf + k] + off + s);
        y[l] = x;
      }
      // 4 x 4 transpose: x_k[l] = input of lane l at sample s + k.
      const Vec a = Shuffle(y[0], y[1], 0, 4, 2, 6);
      const Vec b = Shuffle(y[0], y[1], 1, 5, 3, 7);
      const Vec d = Shuffle(y[2], y[3], 0, 4, 2, 6);
      const Vec e = Shuffle(y[2], y[3], 1, 5, 3, 7);
      Store(xt + s * kLaneWidth, t * Shuffle(a, d, 0, 1, 4, 5));
      Store(xt + (s + 1) * kLaneWidth, t * Shuffle(b, e, 0, 1, 4, 5));
      Store(xt + (s + 2) * kLaneWidth, t * Shuffle(a, d, 2, 3, 6, 7));
      Store(xt + (s + 3) * kLaneWidth, t * Shuffle(b, e, 2, 3, 6, 7));
    }
    for (; s < len; ++s) {
      for (std::size_t l = 0; l < kLaneWidth; ++l) {
        double x = fv[l * nf][off + s];
        for (std::size_t k = 1; k < nf; ++k) x *= fv[l * nf + k][off + s];
        xt[s * kLaneWidth + l] = th[lv + l] * x;
      }
    }
    for (std::size_t qq = 0; qq < nq; ++qq) {
      const Mask sel = {
          q[lv] == static_cast<int>(qq) ? -1 : 0, q[lv + 1] == static_cast<int>(qq) ? -1 : 0,
          q[lv + 2] == static_cast<int>(qq) ? -1 : 0, q[lv + 3] == static_cast<int>(qq) ? -1 : 0};
      double* cq = c + qq * c_stride * kL + lv;
      if (fresh[qq]) {  // c_q = 0 (+ the extra), as LaneSums with no terms, then the add
        const Vec zero = {0.0, 0.0, 0.0, 0.0};
        for (std::size_t k = 0; k < len; ++k) {
          Store(cq + k * kL, sel ? zero + Load(xt + k * kLaneWidth) : zero);
        }
        continue;
      }
      if (!(sel[0] | sel[1] | sel[2] | sel[3])) continue;
      for (std::size_t k = 0; k < len; ++k) {
        const Vec old = Load(cq + k * kL);
        Store(cq + k * kL, sel ? old + Load(xt + k * kLaneWidth) : old);
      }
    }
  }
}

template <int NV>
void LaneExtraNf(const double* const* f, std::size_t nf, std::size_t off, const double* th,
                 const int* q, std::size_t nq, const char* fresh, std::size_t len, double* c,
                 std::size_t c_stride) {
  switch (nf) {
    case 1:
      return LaneExtraT<NV, 1>(f, nf, off, th, q, nq, fresh, len, c, c_stride);
    case 2:
      return LaneExtraT<NV, 2>(f, nf, off, th, q, nq, fresh, len, c, c_stride);
    case 3:
      return LaneExtraT<NV, 3>(f, nf, off, th, q, nq, fresh, len, c, c_stride);
    default:
      return LaneExtraT<NV, 0>(f, nf, off, th, q, nq, fresh, len, c, c_stride);
  }
}

// NF > 0: nf fixed at compile time; 0: nf at run time. x == nullptr: squares.
template <int NV, int NF>
MRD_MULTIVERSION void LaneGramT(const double* const* f, std::size_t nf_rt, std::size_t off,
                                const double* x, std::size_t len, double* acc) {
  const std::size_t nf = NF > 0 ? static_cast<std::size_t>(NF) : nf_rt;
  Vec a[NV];
  for (int v = 0; v < NV; ++v) a[v] = Load(acc + static_cast<std::size_t>(v) * kLaneWidth);
  std::size_t s = 0;
  for (; s + 4 <= len; s += 4) {
    for (int v = 0; v < NV; ++v) {  // independent chains, one per lane vector
      const double* const* fv = f + static_cast<std::size_t>(v) * kLaneWidth * nf;
      Vec y[4];  // y[l]: regressor of lane l at samples s ... s + 3 (factors in order, as Product)
      for (std::size_t l = 0; l < 4; ++l) {
        Vec p = Load(fv[l * nf] + off + s);
        for (std::size_t k = 1; k < nf; ++k) p = p * Load(fv[l * nf + k] + off + s);
        y[l] = p;
      }
      const Vec t0 = Shuffle(y[0], y[1], 0, 4, 2, 6);
      const Vec t1 = Shuffle(y[0], y[1], 1, 5, 3, 7);
      const Vec t2 = Shuffle(y[2], y[3], 0, 4, 2, 6);
      const Vec t3 = Shuffle(y[2], y[3], 1, 5, 3, 7);
      const Vec ph[4] = {Shuffle(t0, t2, 0, 1, 4, 5), Shuffle(t1, t3, 0, 1, 4, 5),
                         Shuffle(t0, t2, 2, 3, 6, 7), Shuffle(t1, t3, 2, 3, 6, 7)};
      for (std::size_t k = 0; k < 4; ++k) {
        a[v] += x != nullptr ? ph[k] * x[off + s + k] : ph[k] * ph[k];
      }
    }
  }
  for (; s < len; ++s) {
    for (int v = 0; v < NV; ++v) {
      const double* const* fv = f + static_cast<std::size_t>(v) * kLaneWidth * nf;
      for (std::size_t l = 0; l < kLaneWidth; ++l) {
        double p = fv[l * nf][off + s];
        for (std::size_t k = 1; k < nf; ++k) p *= fv[l * nf + k][off + s];
        a[v][l] += x != nullptr ? p * x[off + s] : p * p;
      }
    }
  }
  for (int v = 0; v < NV; ++v) Store(acc + static_cast<std::size_t>(v) * kLaneWidth, a[v]);
}

template <int NV>
void LaneGramNf(const double* const* f, std::size_t nf, std::size_t off, const double* x,
                std::size_t len, double* acc) {
  switch (nf) {
    case 1:
      return LaneGramT<NV, 1>(f, nf, off, x, len, acc);
    case 2:
      return LaneGramT<NV, 2>(f, nf, off, x, len, acc);
    case 3:
      return LaneGramT<NV, 3>(f, nf, off, x, len, acc);
    case 4:
      return LaneGramT<NV, 4>(f, nf, off, x, len, acc);
    default:
      return LaneGramT<NV, 0>(f, nf, off, x, len, acc);
  }
}

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

#undef Load
#undef Store
#undef Shuffle
#undef MRD_MULTIVERSION

}  // namespace

void LaneSums(int nv, const double* const* u, std::size_t off, const double* theta, std::size_t m,
              std::size_t len, double* c) {
  switch (nv) {
    case 1:
      return LaneSumsT<1>(u, off, theta, m, len, c);
    case 2:
      return LaneSumsT<2>(u, off, theta, m, len, c);
    case 3:
      return LaneSumsT<3>(u, off, theta, m, len, c);
    default:
      return LaneSumsT<4>(u, off, theta, m, len, c);
  }
}

void LaneFreeRun(int nv, std::size_t nq, const double* c, std::size_t stride, const double* y,
                 const double* w, std::size_t len, double lim, double* p, double* acc, bool* bad) {
  switch (nv) {
    case 1:
      return LaneFreeRunNq<1>(nq, c, stride, y, w, len, lim, p, acc, bad);
    case 2:
      return LaneFreeRunNq<2>(nq, c, stride, y, w, len, lim, p, acc, bad);
    case 3:
      return LaneFreeRunNq<3>(nq, c, stride, y, w, len, lim, p, acc, bad);
    default:
      return LaneFreeRunNq<4>(nq, c, stride, y, w, len, lim, p, acc, bad);
  }
}

void LaneExtra(int nv, const double* const* f, std::size_t nf, std::size_t off, const double* th,
               const int* q, std::size_t nq, const char* fresh, std::size_t len, double* c,
               std::size_t c_stride) {
  switch (nv) {
    case 1:
      return LaneExtraNf<1>(f, nf, off, th, q, nq, fresh, len, c, c_stride);
    case 2:
      return LaneExtraNf<2>(f, nf, off, th, q, nq, fresh, len, c, c_stride);
    case 3:
      return LaneExtraNf<3>(f, nf, off, th, q, nq, fresh, len, c, c_stride);
    default:
      return LaneExtraNf<4>(f, nf, off, th, q, nq, fresh, len, c, c_stride);
  }
}

void LaneGram(int nv, const double* const* f, std::size_t nf, std::size_t off, const double* x,
              std::size_t len, double* acc) {
  switch (nv) {
    case 1:
      return LaneGramNf<1>(f, nf, off, x, len, acc);
    case 2:
      return LaneGramNf<2>(f, nf, off, x, len, acc);
    case 3:
      return LaneGramNf<3>(f, nf, off, x, len, acc);
    default:
      return LaneGramNf<4>(f, nf, off, x, len, acc);
  }
}

void Product(const double* const* cols, std::size_t n, std::size_t off, std::size_t len,
             double* out) {
  ProductT(cols, n, off, len, out);
}

}  // namespace mrd::host::internal
