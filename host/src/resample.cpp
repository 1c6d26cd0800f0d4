#include "mrd/host/resample.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace mrd::host {
namespace {

constexpr int kPhases = 1024;  // kernel table entries per input sample

// Modified Bessel function of the first kind, order 0, by its power series (converges for
// all x; the Kaiser betas used here are below 10, where ~30 terms reach 1e-17).
double BesselI0(double x) {
  const double q = 0.25 * x * x;
  double term = 1.0;
  double sum = 1.0;
  for (int k = 1; k < 200 && term > 1e-17 * sum; ++k) {
    term *= q / (static_cast<double>(k) * static_cast<double>(k));
    sum += term;
  }
  return sum;
}

double KaiserBeta(double atten_db) {
  if (atten_db > 50.0) return 0.1102 * (atten_db - 8.7);
  if (atten_db >= 21.0) {
    return 0.5842 * std::pow(atten_db - 21.0, 0.4) + 0.07886 * (atten_db - 21.0);
  }
  return 0.0;
}

}  // namespace

KaiserLowPass::KaiserLowPass(double pass_hz, double stop_hz, double atten_db)
    : pass_hz_(pass_hz), stop_hz_(stop_hz), atten_db_(atten_db) {
  if (!(pass_hz > 0.0) || !(stop_hz > pass_hz) || !std::isfinite(stop_hz) || !(atten_db > 0.0) ||
      !std::isfinite(atten_db)) {
    throw std::invalid_argument(fmt::format(
        "low-pass: need 0 < pass < stop and attenuation > 0 (pass {} Hz, stop {} Hz, {} dB)",
        pass_hz, stop_hz, atten_db));
  }
  beta_ = KaiserBeta(atten_db);
  i0_beta_ = BesselI0(beta_);
  // Kaiser's length rule N - 1 = (A - 7.95) / (2.285 dw), dw = 2 pi (stop - pass) / R, as a
  // half-width in seconds (independent of R); at least a quarter period of the transition.
  const double transition = stop_hz - pass_hz;
  const double a = std::max(atten_db - 7.95, 0.25 * 2.285 * 2.0 * std::numbers::pi);
  half_width_s_ = a / (2.0 * 2.285 * 2.0 * std::numbers::pi * transition);
}

std::size_t KaiserLowPass::Taps(double rate_hz) const {
  if (!(half_width_s_ * rate_hz < 1e15)) throw std::invalid_argument("filter kernel too long");
  return 2 * static_cast<std::size_t>(std::floor(half_width_s_ * rate_hz)) + 1;
}

double KaiserLowPass::Evaluate(double tau_s) const {
  const double r = tau_s / half_width_s_;
  if (std::fabs(r) > 1.0) return 0.0;
  const double fc = cutoff_hz();
  const double arg = 2.0 * fc * tau_s;
  const double sinc =
      std::fabs(arg) < 1e-12 ? 1.0 : std::sin(std::numbers::pi * arg) / (std::numbers::pi * arg);
  const double window = BesselI0(beta_ * std::sqrt(std::max(0.0, 1.0 - r * r))) / i0_beta_;
  return 2.0 * fc * sinc * window;
}

std::string KaiserLowPass::Describe(double rate_hz) const {
  return fmt::format(
      "Kaiser-windowed sinc low-pass, zero phase: pass 0-{:g} Hz, stop >= {:g} Hz at {:g} dB "
      "(-6 dB at {:g} Hz, beta {:.3f}, {} taps at {:g} Hz)",
      pass_hz_, stop_hz_, atten_db_, cutoff_hz(), beta_, Taps(rate_hz), rate_hz);
}

KaiserLowPass AntiAliasFilter(double in_rate_hz, double out_rate_hz) {
  const double r = std::min(in_rate_hz, out_rate_hz);
  return KaiserLowPass(0.4 * r, 0.5 * r, 80.0);
}

std::vector<double> FilterAt(std::span<const double> x, double rate_hz, const KaiserLowPass& lp,
                             double step, std::size_t out_rows) {
  if (!(rate_hz > 0.0) || !(step > 0.0) || !std::isfinite(step)) {
    throw std::invalid_argument("FilterAt: rate and step must be positive");
  }
  const std::size_t n = x.size();
  const double half_width = lp.half_width_s() * rate_hz;  // [samples]
  // Compared as doubles first: a tiny time step makes the half-width exceed any integer.
  if (!(std::floor(half_width) + 2.0 <= static_cast<double>(n))) {
    throw std::invalid_argument(fmt::format(
        "filter needs at least {:.4g} samples (kernel half-width {:.4g} samples), have {}",
        std::floor(half_width) + 2.0, std::floor(half_width), n));
  }
  const auto w = static_cast<std::ptrdiff_t>(std::floor(half_width));
  if (n < static_cast<std::size_t>(w) + 2) {
    throw std::invalid_argument(fmt::format(
        "filter needs at least {} samples (kernel half-width {} samples), have {}", w + 2, w, n));
  }
  const double last = static_cast<double>(n - 1);
  if (out_rows > 0 && static_cast<double>(out_rows - 1) * step > last + 1e-9) {
    throw std::invalid_argument("FilterAt: output instants run past the last input sample");
  }

  // Kernel table: tab[j] = h(j / (kPhases R)) / R for j = 0 ... (w + 1) kPhases (+1 spare).
  const std::size_t entries = static_cast<std::size_t>(w + 1) * kPhases + 2;
  std::vector<double> tab(entries);
  for (std::size_t j = 0; j < entries; ++j) {
    tab[j] = lp.Evaluate(static_cast<double>(j) / (kPhases * rate_hz)) / rate_hz;
  }
  const auto at = [&](std::ptrdiff_t k) {  // odd reflection about both ends
    const auto last_i = static_cast<std::ptrdiff_t>(n - 1);
    if (k < 0) return 2.0 * x[0] - x[static_cast<std::size_t>(-k)];
    if (k > last_i) return 2.0 * x[n - 1] - x[static_cast<std::size_t>(2 * last_i - k)];
    return x[static_cast<std::size_t>(k)];
  };

  std::vector<double> y(out_rows);
  for (std::size_t i = 0; i < out_rows; ++i) {
    const double u = std::min(static_cast<double>(i) * step, last);
    const auto k0 = static_cast<std::ptrdiff_t>(std::ceil(u - half_width));
    const auto k1 = static_cast<std::ptrdiff_t>(std::floor(u + half_width));
    double acc = 0.0;
    double wsum = 0.0;
    for (std::ptrdiff_t k = k0; k <= k1; ++k) {
      const double p = std::fabs(u - static_cast<double>(k)) * kPhases;
      const auto j = static_cast<std::size_t>(p);
      const double frac = p - static_cast<double>(j);
      const double h = tab[j] + frac * (tab[j + 1] - tab[j]);
      acc += h * at(k);
      wsum += h;
    }
    y[i] = acc / wsum;
  }
  return y;
}

std::vector<double> LowPassZeroPhase(std::span<const double> x, double rate_hz,
                                     const KaiserLowPass& lp) {
  return FilterAt(x, rate_hz, lp, 1.0, x.size());
}

std::size_t ResampledRows(std::size_t in_rows, double in_rate_hz, double out_rate_hz) {
  if (in_rows == 0) return 0;
  const double span_out = static_cast<double>(in_rows - 1) * out_rate_hz / in_rate_hz;
  return static_cast<std::size_t>(std::floor(span_out + 1e-9)) + 1;
}

std::vector<double> Resample(std::span<const double> x, double in_rate_hz, double out_rate_hz) {
  if (!(in_rate_hz > 0.0) || !(out_rate_hz > 0.0)) {
    throw std::invalid_argument("Resample: rates must be positive");
  }
  return FilterAt(x, in_rate_hz, AntiAliasFilter(in_rate_hz, out_rate_hz), in_rate_hz / out_rate_hz,
                  ResampledRows(x.size(), in_rate_hz, out_rate_hz));
}

std::vector<double> CentralDifference(std::span<const double> x, double rate_hz) {
  const std::size_t n = x.size();
  if (n < 3 || !(rate_hz > 0.0)) {
    throw std::invalid_argument("CentralDifference: need >= 3 samples and a positive rate");
  }
  std::vector<double> d(n);
  const double half_r = 0.5 * rate_hz;
  d[0] = (-3.0 * x[0] + 4.0 * x[1] - x[2]) * half_r;
  for (std::size_t k = 1; k + 1 < n; ++k) d[k] = (x[k + 1] - x[k - 1]) * half_r;
  d[n - 1] = (3.0 * x[n - 1] - 4.0 * x[n - 2] + x[n - 3]) * half_r;
  return d;
}

KaiserLowPass VelocityFilter(double cutoff_hz) {
  return KaiserLowPass(0.75 * cutoff_hz, 1.25 * cutoff_hz, 60.0);
}

std::vector<double> DeriveVelocity(std::span<const double> x, double rate_hz, double cutoff_hz) {
  if (!(cutoff_hz > 0.0) || !(1.25 * cutoff_hz < 0.5 * rate_hz)) {
    throw std::invalid_argument(fmt::format(
        "velocity cut-off {:g} Hz: must be > 0 and 1.25 x cut-off below the Nyquist rate {:g} Hz",
        cutoff_hz, 0.5 * rate_hz));
  }
  return CentralDifference(LowPassZeroPhase(x, rate_hz, VelocityFilter(cutoff_hz)), rate_hz);
}

}  // namespace mrd::host
