#pragma once
// Inner loops of the SEM engine's fast free run (sem.cpp, Engine::SimulateFast) and of its
// Gram products (Engine::Cross), vectorised across jobs. Not public.
//
// Cost model (paper run: N = 40k samples, 1551 candidates, m <= 14 model terms, 20
// iterations): per major iteration every admissible candidate is one job whose free run
// costs m multiply-adds per sample for c_q(k) = sum theta_i u_i(k) plus a Horner step in
// y(k-1); early stopping ends only ~7 % of that work (most candidates end near the current
// J, so their partial cost passes the best J late). Total ~8.6e9 multiply-adds for the sums
// and ~1e9 recursion steps. The scalar loop per job was bound by the load of u_i(k) per
// multiply-add and by the latency of the recursion (one dependent chain of 4 FP operations
// per sample). Here kLanes jobs run in lockstep, one per SIMD lane: each u_i(k) is loaded
// once for all lanes, and the recursion has kLanes independent chains. Each job's arithmetic
// is exactly the sequence of the scalar reference (same operations, same order, no FMA), so
// every result is bit for bit the same on every CPU and thread count; AVX2 is used when the
// CPU has it (function multi-versioning), plain SSE2 otherwise.

#include <cstddef>

namespace mrd::host::internal {

inline constexpr std::size_t kLaneWidth = 4;              // doubles per SIMD vector
inline constexpr std::size_t kMaxLanes = 4 * kLaneWidth;  // jobs per lane group
inline constexpr std::size_t kSubBlock = 32;  // samples per pass (the lane sums stay in L1)

// Lane sums over one group of model terms (those of one y power q), for lanes = 4 * nv jobs:
// c[s * lanes + l] = sum_j theta[j * lanes + l] * u[j][off + s], s < len, j < m, summed as
// the scalar reference: terms in fours ((t0 a0 + t1 a1) + (t2 a2 + t3 a3)), then singly;
// 0 when m = 0.
void LaneSums(int nv, const double* const* u, std::size_t off, const double* theta, std::size_t m,
              std::size_t len, double* c);

// Advances lanes = 4 * nv free runs y(k) = sum_q c_q(k) y(k-1)^q (Horner) over len samples,
// c_q(s) = c[(q * stride + s) * lanes + l]; per lane: p the previous output (in/out), acc the
// running sum of w (y - y_sim)^2 (in/out), bad set when |y_sim| > lim or NaN (in/out).
void LaneFreeRun(int nv, std::size_t nq, const double* c, std::size_t stride, const double* y,
                 const double* w, std::size_t len, double lim, double* p, double* acc, bool* bad);

// Adds each lane's extra candidate: c[(q[l] * c_stride + s) * lanes + l] += th[l] * x_l(s)
// for s < len (<= kSubBlock) and lanes l (4 * nv) with 0 <= q[l] < nq (q[l] < 0: none), x_l(s)
// the product of f[l * nf + k][off + s] over k < nf (nf >= 1) in order of k (pad with columns
// of ones: x * 1 = x exactly). fresh[q] != 0: c_q is not read but written as 0 + the extras
// (the y power q has no model term; LaneSums was not called for it).
void LaneExtra(int nv, const double* const* f, std::size_t nf, std::size_t off, const double* th,
               const int* q, std::size_t nq, const char* fresh, std::size_t len, double* c,
               std::size_t c_stride);

// out[i] = product of cols[f][off + i] over f < n, multiplied in order of f (1 when n = 0).
void Product(const double* const* cols, std::size_t n, std::size_t off, std::size_t len,
             double* out);

// Gram sums of lanes = 4 * nv regressors: acc[l] += sum_i phi_l(i) x(i) (x == nullptr:
// phi_l(i)^2) over i in [off, off + len), each sum in order of i (the scalar reference's
// order); phi_l(i) the product of f[l * nf + k][i] over k < nf (nf >= 1) in order of k.
void LaneGram(int nv, const double* const* f, std::size_t nf, std::size_t off, const double* x,
              std::size_t len, double* acc);

}  // namespace mrd::host::internal
