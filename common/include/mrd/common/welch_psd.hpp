#pragma once
// One-sided power spectral density by Welch's method: Hann-windowed segments of `segment`
// samples (a power of two), 50 % overlap, periodograms averaged, scaled as a density
//
//   P(f_k) = c |sum_n w_n x_n e^{-j 2 pi k n / N}|^2 / (fs sum_n w_n^2),  f_k = k fs / N,
//
// c = 2 for 0 < k < N/2 (the negative frequencies folded in), 1 at 0 and N/2, so that
// sum_k P(f_k) fs / N is the mean-square of the (detrended-free) signal: [unit^2 / Hz].
// Each segment's mean is removed first. Not real-time (allocates).

#include <cstddef>
#include <vector>

namespace mrd {

struct Psd {
  std::vector<double> f_hz;     // 0 .. fs/2, N/2 + 1 bins
  std::vector<double> density;  // [unit^2 / Hz]
  int segments = 0;             // averaged periodograms
};

// false when segment is not a power of two >= 8, fs <= 0, or x is shorter than one segment.
bool WelchPsd(const std::vector<double>& x, double fs_hz, std::size_t segment, Psd* out);

}  // namespace mrd
