#pragma once
// ISO 2631-1:1997 frequency weighting Wk (vertical whole-body vibration, seated/standing:
// the comfort figure of a body acceleration), Annex A. The weighting is the product of
//
//   band limiting   Hh(p) = 1 / (1 + sqrt(2) w1/p + (w1/p)^2)            high-pass, f1 = 0.4 Hz
//                   Hl(p) = 1 / (1 + sqrt(2) p/w2 + (p/w2)^2)            low-pass,  f2 = 100 Hz
//   a-v transition  Ht(p) = (1 + p/w3) / (1 + p/(Q4 w4) + (p/w4)^2)      f3 = f4 = 12.5 Hz,
//                                                                        Q4 = 0.63
//   upward step     Hs(p) = (1 + p/(Q5 w5) + (p/w5)^2) /
//                           (1 + p/(Q6 w6) + (p/w6)^2) * (w5/w6)^2       f5 = 2.37 Hz, Q5 = 0.91,
//                                                                        f6 = 3.35 Hz, Q6 = 0.91
//
// with p = j 2 pi f and wi = 2 pi fi (ISO 2631-1 equations A.1..A.4, Table A.2 row Wk).
// Iso2631WkGain is |Hh Hl Ht Hs| at f (the standard's Table 3 tabulates it, rounded to three
// digits). WkFilter realises each factor as one digital biquad by the bilinear transform,
// pre-warped at the factor's own corner (f1, f2, f4, sqrt(f5 f6)), so every corner sits at its
// analog frequency; the residual warping error grows towards Nyquist (at 1 kHz: < 1 % of the
// analog gain up to 50 Hz, see tests/common/iso2631_weighting_test.cpp).

#include <array>

namespace mrd {

// |Wk(f)| [-] of the analog weighting at f [Hz] (f >= 0; 0 at f = 0).
double Iso2631WkGain(double f_hz);

// Wk as a cascade of four biquads at a fixed sample rate. Real-time safe (no allocation).
class WkFilter {
 public:
  // fs_hz: sample rate [Hz], > 2 * 100 Hz (the low-pass corner must lie below Nyquist).
  explicit WkFilter(double fs_hz);
  // Back to rest (zero input history).
  void Reset();
  // One input sample [any unit] -> the weighted sample [same unit].
  double Step(double x);
  // |H(e^{j 2 pi f / fs})| of the digital cascade at f [Hz] (0 <= f <= fs / 2).
  double Gain(double f_hz) const;
  double fs_hz() const { return fs_; }

 private:
  struct Biquad {
    double b0, b1, b2, a1, a2;  // y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2
    double x1 = 0.0, x2 = 0.0, y1 = 0.0, y2 = 0.0;
  };
  double fs_;
  std::array<Biquad, 4> stages_{};
};

}  // namespace mrd
