#pragma once
// Off-line H2/LQG design of the clipped-optimal controller for the shear frame
// (shear_frame.hpp): discretised at the control period, a discrete LQR gain on the floor
// displacements and a discrete Kalman predictor on the measured absolute floor accelerations,
// ground acceleration as white process noise (Dyke et al. 1996). Host only (Eigen).

#include <array>
#include <string>

#include "mrd/firmware/clipped_optimal.hpp"
#include "mrd/sim/shear_frame.hpp"

namespace mrd::structure {

struct DesignOptions {
  double period_s = 1e-3;        // control period T [s]
  double q_displacement = 1e10;  // LQR weight on each floor displacement [1/m^2]
  double q_drift = 0.0;          // LQR weight on each inter-story drift [1/m^2]
  double r_force = 1.0;          // LQR weight on the force [1/N^2]
  double noise_ratio = 25.0;     // ground-acceleration / measurement-noise PSD ratio (gamma_g)
  double v_max = 2.25;           // clipped rule voltage [V]
};

// Modal frequencies [Hz] and damping ratios [-] of the bare frame, ascending.
struct Modes {
  std::array<double, 3> frequency_hz{};
  std::array<double, 3> damping_ratio{};
};
Modes FrameModes(const ShearFrameParams& frame);

// The design for the frame's dampers (frame.dampers at frame.story: B has one column per
// damper, K one row, the Kalman predictor takes every damper's measured force as a known
// input; r_force weighs each force alike). Returns false with *error set when a Riccati
// iteration does not converge, the damper set is invalid or an option is out of range
// (period, weights > 0 where required).
bool DesignClippedOptimal(const ShearFrameParams& frame, const DesignOptions& options,
                          firmware::ClippedOptimalGains* gains, std::string* error);

// The gains as TOML ([control.clipped_optimal] table: ad, bd, cy, dy, l, k, v_max, v_min; and
// dampers = m when m > 1, the one-damper file staying as it was).
std::string GainsToml(const firmware::ClippedOptimalGains& gains, const DesignOptions& options);

}  // namespace mrd::structure
