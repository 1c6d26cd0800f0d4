#pragma once
// Zero-phase FIR low-pass filtering, band-limited resampling to an arbitrary (non-integer)
// rate, and filtered differentiation of uniformly sampled signals. Host only (allocates).

#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace mrd::host {

// Kaiser-windowed sinc low-pass as a continuous-time kernel (Kaiser 1974 design rules):
//
//   h(tau) = 2 fc sinc(2 fc tau) * I0(beta sqrt(1 - (tau/T)^2)) / I0(beta),  |tau| <= T
//   fc = (pass + stop) / 2  (-6 dB point),  T = (A - 7.95) / (4.57 * 2 pi (stop - pass))
//   beta = 0.1102 (A - 8.7) for A > 50 dB, 0.5842 (A - 21)^0.4 + 0.07886 (A - 21) for
//   21 <= A <= 50, 0 below.
//
// Symmetric, hence zero phase. Sampled at rate R it gives a FIR of about 2 T R + 1 taps whose
// gain is 1 +- 10^(-A/20) below `pass` and at most 10^(-A/20) above `stop`.
class KaiserLowPass {
 public:
  // pass_hz < stop_hz, both > 0 [Hz]; atten_db > 0 [dB]. Throws std::invalid_argument.
  KaiserLowPass(double pass_hz, double stop_hz, double atten_db);

  double pass_hz() const { return pass_hz_; }
  double stop_hz() const { return stop_hz_; }
  double cutoff_hz() const { return 0.5 * (pass_hz_ + stop_hz_); }
  double atten_db() const { return atten_db_; }
  double beta() const { return beta_; }
  double half_width_s() const { return half_width_s_; }  // T [s]
  // Taps when sampled at rate_hz (odd count, 2 floor(T R) + 1).
  std::size_t Taps(double rate_hz) const;

  // h(tau) [1/s]; 0 for |tau| > T.
  double Evaluate(double tau_s) const;

  // One line: band edges, attenuation, beta, taps at rate_hz.
  std::string Describe(double rate_hz) const;

 private:
  double pass_hz_;
  double stop_hz_;
  double atten_db_;
  double beta_;
  double half_width_s_;
  double i0_beta_;
};

// Anti-aliasing filter for resampling from in_rate_hz to out_rate_hz: with R = the lower of
// the two rates, pass band 0 ... 0.4 R, stop band from 0.5 R (the lower Nyquist), 80 dB.
KaiserLowPass AntiAliasFilter(double in_rate_hz, double out_rate_hz);

// Evaluates the filtered signal at the instants u_n = n * step (n = 0 ... out_rows - 1) in
// units of input samples (u = 0 is x[0]):
//
//   y_n = sum_k x~[k] h((u_n - k) / R) / sum_k h((u_n - k) / R)
//
// The kernel is tabulated at 1024 phases per input sample with linear interpolation between
// phases (error < 1e-6 of the peak); dividing by the weight sum makes the DC gain exactly 1
// at every phase. Ends: x~ extends x by odd reflection about x[0] and x[N-1]
// (x~[-k] = 2 x[0] - x[k]), which preserves value and slope there.
// Throws std::invalid_argument when step <= 0, rate_hz <= 0, or x has fewer samples than the
// kernel half-width + 2 (the reflection would run out of data), or an instant lies beyond
// x[N-1].
std::vector<double> FilterAt(std::span<const double> x, double rate_hz, const KaiserLowPass& lp,
                             double step, std::size_t out_rows);

// Zero-phase low-pass at the input rate: FilterAt with step 1, same length as x.
std::vector<double> LowPassZeroPhase(std::span<const double> x, double rate_hz,
                                     const KaiserLowPass& lp);

// Rows of a resampled signal spanning the same duration: floor((N - 1) out / in) + 1, with
// a 1e-9 sample tolerance so an exact multiple keeps its last instant.
std::size_t ResampledRows(std::size_t in_rows, double in_rate_hz, double out_rate_hz);

// Resamples x (uniform at in_rate_hz, first sample at time 0) to out_rate_hz at instants
// n / out_rate_hz through AntiAliasFilter; ResampledRows(...) rows. Any ratio, integer or not.
std::vector<double> Resample(std::span<const double> x, double in_rate_hz, double out_rate_hz);

// Central differences (x[k+1] - x[k-1]) R / 2 [units/s]; second-order one-sided differences at
// the two ends. Gain sin(w/R)/(w/R) at angular frequency w: -0.18 % at R/60.
// Throws std::invalid_argument for fewer than 3 samples or rate_hz <= 0.
std::vector<double> CentralDifference(std::span<const double> x, double rate_hz);

// Filter used by DeriveVelocity for cut-off fc: -6 dB at fc, pass band 0 ... 0.75 fc, stop band
// from 1.25 fc, 60 dB.
KaiserLowPass VelocityFilter(double cutoff_hz);

// Filtered differentiator: LowPassZeroPhase with VelocityFilter(cutoff_hz), then
// CentralDifference. Zero phase. Throws std::invalid_argument when 1.25 cutoff_hz is not
// below rate_hz / 2, or for the reasons of FilterAt.
std::vector<double> DeriveVelocity(std::span<const double> x, double rate_hz, double cutoff_hz);

}  // namespace mrd::host
