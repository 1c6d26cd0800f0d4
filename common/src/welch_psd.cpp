// Welch PSD (welch_psd.hpp) with an iterative radix-2 FFT.
#include "mrd/common/welch_psd.hpp"

#include <cmath>
#include <complex>

namespace mrd {
namespace {

constexpr double kPi = 3.14159265358979323846;

// In place, a.size() a power of two.
void Fft(std::vector<std::complex<double>>* data) {
  std::vector<std::complex<double>>& a = *data;
  const std::size_t n = a.size();
  for (std::size_t i = 1, j = 0; i < n; ++i) {
    std::size_t bit = n >> 1;
    for (; (j & bit) != 0; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(a[i], a[j]);
  }
  for (std::size_t len = 2; len <= n; len <<= 1) {
    const std::complex<double> wl = std::polar(1.0, -2 * kPi / static_cast<double>(len));
    for (std::size_t i = 0; i < n; i += len) {
      std::complex<double> w(1.0, 0.0);
      for (std::size_t k = 0; k < len / 2; ++k) {
        const std::complex<double> u = a[i + k], v = a[i + k + len / 2] * w;
        a[i + k] = u + v;
        a[i + k + len / 2] = u - v;
        w *= wl;
      }
    }
  }
}

}  // namespace

bool WelchPsd(const std::vector<double>& x, double fs_hz, std::size_t segment, Psd* out) {
  if (segment < 8 || (segment & (segment - 1)) != 0 || !(fs_hz > 0.0) || x.size() < segment) {
    return false;
  }
  std::vector<double> w(segment);
  double w2 = 0.0;
  for (std::size_t n = 0; n < segment; ++n) {
    w[n] = 0.5 - 0.5 * std::cos(2 * kPi * static_cast<double>(n) / static_cast<double>(segment));
    w2 += w[n] * w[n];
  }
  const std::size_t half = segment / 2;
  out->f_hz.assign(half + 1, 0.0);
  out->density.assign(half + 1, 0.0);
  out->segments = 0;
  std::vector<std::complex<double>> buf(segment);
  for (std::size_t start = 0; start + segment <= x.size(); start += half) {
    double mean = 0.0;
    for (std::size_t n = 0; n < segment; ++n) mean += x[start + n];
    mean /= static_cast<double>(segment);
    for (std::size_t n = 0; n < segment; ++n) buf[n] = (x[start + n] - mean) * w[n];
    Fft(&buf);
    for (std::size_t k = 0; k <= half; ++k) out->density[k] += std::norm(buf[k]);
    ++out->segments;
  }
  const double scale = 1.0 / (fs_hz * w2 * static_cast<double>(out->segments));
  for (std::size_t k = 0; k <= half; ++k) {
    out->f_hz[k] = static_cast<double>(k) * fs_hz / static_cast<double>(segment);
    out->density[k] *= scale * ((k == 0 || k == half) ? 1.0 : 2.0);
  }
  return true;
}

}  // namespace mrd
