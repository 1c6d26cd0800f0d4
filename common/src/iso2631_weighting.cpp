// ISO 2631-1 Wk weighting (iso2631_weighting.hpp): the analog magnitude and its bilinear
// biquad cascade.
#include "mrd/common/iso2631_weighting.hpp"

#include <cmath>
#include <complex>

namespace mrd {
namespace {

constexpr double kPi = 3.14159265358979323846;
// ISO 2631-1 Table A.2, row Wk [Hz, -].
constexpr double kF1 = 0.4, kF2 = 100.0, kF3 = 12.5, kF4 = 12.5, kQ4 = 0.63;
constexpr double kF5 = 2.37, kQ5 = 0.91, kF6 = 3.35, kQ6 = 0.91;

// An analog biquad (n0 + n1 p + n2 p^2) / (d0 + d1 p + d2 p^2).
struct Analog {
  double n0, n1, n2, d0, d1, d2;
  double warp_hz;  // pre-warping frequency of its bilinear transform
};

std::array<Analog, 4> Sections() {
  const double w1 = 2 * kPi * kF1, w2 = 2 * kPi * kF2, w3 = 2 * kPi * kF3, w4 = 2 * kPi * kF4;
  const double w5 = 2 * kPi * kF5, w6 = 2 * kPi * kF6;
  const double r = std::sqrt(2.0);
  const double g = (w5 / w6) * (w5 / w6);
  return {{
      {0.0, 0.0, 1.0, w1 * w1, r * w1, 1.0, kF1},          // Hh = p^2 / (p^2 + r w1 p + w1^2)
      {1.0, 0.0, 0.0, 1.0, r / w2, 1.0 / (w2 * w2), kF2},  // Hl
      {1.0, 1.0 / w3, 0.0, 1.0, 1.0 / (kQ4 * w4), 1.0 / (w4 * w4), kF4},  // Ht
      {g, g / (kQ5 * w5), g / (w5 * w5), 1.0, 1.0 / (kQ6 * w6), 1.0 / (w6 * w6),
       std::sqrt(kF5 * kF6)},  // Hs
  }};
}

std::complex<double> Eval(const Analog& a, std::complex<double> p) {
  return (a.n0 + p * (a.n1 + p * a.n2)) / (a.d0 + p * (a.d1 + p * a.d2));
}

}  // namespace

double Iso2631WkGain(double f_hz) {
  if (!(f_hz > 0.0)) return 0.0;
  const std::complex<double> p(0.0, 2 * kPi * f_hz);
  std::complex<double> h(1.0, 0.0);
  for (const Analog& a : Sections()) h *= Eval(a, p);
  return std::abs(h);
}

WkFilter::WkFilter(double fs_hz) : fs_(fs_hz) {
  const std::array<Analog, 4> sections = Sections();
  for (std::size_t i = 0; i < sections.size(); ++i) {
    const Analog& a = sections[i];
    // s = K (1 - z^-1) / (1 + z^-1), K = w0 / tan(w0 T / 2): exact at w0.
    const double w0 = 2 * kPi * a.warp_hz;
    const double k = w0 / std::tan(w0 / (2.0 * fs_hz));
    const double k2 = k * k;
    const double b0 = a.n0 + a.n1 * k + a.n2 * k2, b1 = 2.0 * (a.n0 - a.n2 * k2),
                 b2 = a.n0 - a.n1 * k + a.n2 * k2;
    const double a0 = a.d0 + a.d1 * k + a.d2 * k2, a1 = 2.0 * (a.d0 - a.d2 * k2),
                 a2 = a.d0 - a.d1 * k + a.d2 * k2;
    stages_[i] = {b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0};
  }
}

void WkFilter::Reset() {
  for (Biquad& b : stages_) b.x1 = b.x2 = b.y1 = b.y2 = 0.0;
}

double WkFilter::Step(double x) {
  for (Biquad& b : stages_) {
    const double y = b.b0 * x + b.b1 * b.x1 + b.b2 * b.x2 - b.a1 * b.y1 - b.a2 * b.y2;
    b.x2 = b.x1;
    b.x1 = x;
    b.y2 = b.y1;
    b.y1 = y;
    x = y;
  }
  return x;
}

double WkFilter::Gain(double f_hz) const {
  const std::complex<double> z1 = std::polar(1.0, -2 * kPi * f_hz / fs_);  // z^-1
  std::complex<double> h(1.0, 0.0);
  for (const Biquad& b : stages_) {
    h *= (b.b0 + z1 * (b.b1 + z1 * b.b2)) / (1.0 + z1 * (b.a1 + z1 * b.a2));
  }
  return std::abs(h);
}

}  // namespace mrd
