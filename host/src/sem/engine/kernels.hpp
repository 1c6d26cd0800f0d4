#pragma once
// Inner loops of the SEM engine (host/src/sem/engine/engine.cpp, Engine): the fast free run of many
// jobs and the Gram sums of the candidates, vectorised across jobs (one job per SIMD lane). Not
// public.
//
// Cost model (paper run: N = 40k samples, 1551 candidates, m <= 14 model terms, 20 major
// iterations). Per iteration every admissible candidate is one job whose free run costs, per
// sample, m multiply-adds for c_q(k) = sum_i theta_i u_i(k) (LaneSums), the candidate's own
// input product and add (LaneExtra) and a Horner step in y(k-1) (LaneFreeRun). Early stopping
// ends only ~7 % of that work: most candidates end near the current J, so their partial cost
// passes the best J late. Whole run: ~1.0e9 job-samples, ~8.6e9 multiply-adds in the sums;
// and per term entering the model one Gram sum over N for every candidate (Cross, LaneGram:
// ~20 x 1551 x N = 1.2e9 products). The scalar code was bound by loads (u_i(k) per
// multiply-add), by the latency of the one recursion chain and of the one Gram sum chain,
// and by cache misses (16 jobs per sweep over ~13 MB of columns). Here 16 jobs (4 vectors of
// 4 lanes) run in lockstep: u_i(k) is loaded once for all lanes, the recursion and the sums
// have 16 independent chains, a 4 x 4 transpose turns per-candidate columns into lanes, and a
// sweep serves a work item's jobs (up to kSweep = 256 in best improvement, kRound / threads in
// first improvement: host/src/sem/search/search.cpp). Profile of the result (perf, 1 thread): lane
// sums ~22 %, extras ~20 %, Gram ~14 %, recursion ~12 %.
//
// Each job's arithmetic is exactly the sequence of the scalar reference (same operations in
// the same order, no FMA), so every J, coefficient and decision is bit for bit the same on
// every CPU and thread count; AVX2 is used when the CPU has it (function multi-versioning),
// SSE2 otherwise. Where the CPU has AVX-512F, the same code runs 8 lanes per vector (32 jobs
// per group, 8 x 8 transposes; kernels_avx512.cpp): the same bits, fewer instructions.

#include <cstddef>

namespace mrd::host::internal {

inline constexpr std::size_t kMaxLaneWidth = 8;
inline constexpr std::size_t kMaxLanes = 4 * kMaxLaneWidth;  // most jobs per lane group
inline constexpr std::size_t kSubBlock = 32;  // samples per pass (lane sums stay in L1)

// Doubles per vector of the kernels in use: 8 where the build has the AVX-512 kernels (x86-64)
// and the CPU has AVX-512F, else 4. A lane group is nv <= 4 vectors: 4 * LaneWidth() jobs.
std::size_t LaneWidth();

// Makes the kernels use vectors of w doubles (4, or 8 where available; 0: the widest
// available); false, and nothing changed, when w is not available. For tests and benchmarks
// (not while kernels run).
bool SetLaneWidth(std::size_t w);

// Lane sums over one group of model terms (those of one y power q), for lanes = LaneWidth() * nv
// jobs: c[s * lanes + l] = sum_j theta[j * lanes + l] * u[j][off + s], s < len, j < m, summed as
// the scalar reference: terms in fours ((t0 a0 + t1 a1) + (t2 a2 + t3 a3)), then singly;
// 0 when m = 0.
void LaneSums(int nv, const double* const* u, std::size_t off, const double* theta, std::size_t m,
              std::size_t len, double* c);

// Advances lanes = LaneWidth() * nv free runs y(k) = sum_q c_q(k) y(k-1)^q (Horner) over len
// samples, c_q(s) = c[(q * stride + s) * lanes + l]; per lane: p the previous output (in/out), acc
// the running sum of w (y - y_sim)^2 (in/out), bad set when |y_sim| > lim or NaN (in/out).
void LaneFreeRun(int nv, std::size_t nq, const double* c, std::size_t stride, const double* y,
                 const double* w, std::size_t len, double lim, double* p, double* acc, bool* bad);

// Adds each lane's extra candidate: c[(q[l] * c_stride + s) * lanes + l] += th[l] * x_l(s)
// for s < len (<= kSubBlock) and lanes l (LaneWidth() * nv) with 0 <= q[l] < nq (q[l] < 0: none),
// x_l(s) the product of f[l * nf + k][off + s] over k < nf (nf >= 1) in order of k (pad with
// columns of ones: x * 1 = x exactly). fresh[q] != 0: c_q is not read but written as 0 + the extras
// (the y power q has no model term; LaneSums was not called for it).
void LaneExtra(int nv, const double* const* f, std::size_t nf, std::size_t off, const double* th,
               const int* q, std::size_t nq, const char* fresh, std::size_t len, double* c,
               std::size_t c_stride);

// out[i] = product of cols[f][off + i] over f < n, multiplied in order of f (1 when n = 0).
void Product(const double* const* cols, std::size_t n, std::size_t off, std::size_t len,
             double* out);

// Gram sums of lanes = LaneWidth() * nv regressors: acc[l] += sum_i phi_l(i) x(i) (x == nullptr:
// phi_l(i)^2) over i in [off, off + len), each sum in order of i (the scalar reference's
// order); phi_l(i) the product of f[l * nf + k][i] over k < nf (nf >= 1) in order of k.
void LaneGram(int nv, const double* const* f, std::size_t nf, std::size_t off, const double* x,
              std::size_t len, double* acc);

// The kernels of one vector width (kernels_impl.inc), the functions above dispatch to: w4
// (4 doubles per vector) and, in x86-64 builds, w8 (8 doubles, AVX-512F; kernels_avx512.cpp).
struct KernelSet {
  decltype(&LaneSums) lane_sums;
  decltype(&LaneFreeRun) lane_free_run;
  decltype(&LaneExtra) lane_extra;
  decltype(&LaneGram) lane_gram;
};
namespace w4 {
extern const KernelSet kKernels;
}
namespace w8 {
extern const KernelSet kKernels;
}

}  // namespace mrd::host::internal
