#pragma once
// The structure plant's scores (structure_plant.hpp): peak and RMS floor displacements,
// inter-story drifts and absolute floor accelerations, and the peak and RMS damper force, over
// every step of the run; for the controlled run and its passive twins (0 V, E_max), as the
// in-process study's table (docs/structure.md) has them. Units: cm, cm/s^2, N.

#include <cmath>
#include <cstdint>

#include "mrd/sim/shear_frame.hpp"

namespace mrd::hil {

struct StructureFigures {
  std::uint64_t samples = 0;
  double peak_x_cm[3] = {}, rms_x_cm[3] = {};          // floor displacement rel. ground
  double peak_d_cm[3] = {}, rms_d_cm[3] = {};          // inter-story drift
  double peak_xa_cm_s2[3] = {}, rms_xa_cm_s2[3] = {};  // absolute acceleration
  double peak_force_n = 0.0, rms_force_n = 0.0;        // damper force
  double peak_drift_cm() const {
    return std::fmax(peak_d_cm[0], std::fmax(peak_d_cm[1], peak_d_cm[2]));
  }
  double peak_accel_cm_s2() const {
    return std::fmax(peak_xa_cm_s2[0], std::fmax(peak_xa_cm_s2[1], peak_xa_cm_s2[2]));
  }
};

struct StructureScores {
  StructureFigures controlled, passive_off, passive_on;
};

// Accumulates one run's figures, a sample per step. No allocation.
class StructureMetrics {
 public:
  void Add(const ShearFrameSample& s) {
    ++n_;
    for (int i = 0; i < 3; ++i) {
      const double x = 100.0 * s.x[i];
      const double d = 100.0 * (s.x[i] - (i > 0 ? s.x[i - 1] : 0.0));
      const double a = 100.0 * s.xa[i];
      f_.peak_x_cm[i] = std::fmax(f_.peak_x_cm[i], std::fabs(x));
      f_.peak_d_cm[i] = std::fmax(f_.peak_d_cm[i], std::fabs(d));
      f_.peak_xa_cm_s2[i] = std::fmax(f_.peak_xa_cm_s2[i], std::fabs(a));
      x2_[i] += x * x;
      d2_[i] += d * d;
      a2_[i] += a * a;
    }
    f_.peak_force_n = std::fmax(f_.peak_force_n, std::fabs(s.force));
    f2_ += s.force * s.force;
  }
  StructureFigures Figures() const {
    StructureFigures f = f_;
    f.samples = n_;
    const double n = n_ > 0 ? static_cast<double>(n_) : 1.0;
    for (int i = 0; i < 3; ++i) {
      f.rms_x_cm[i] = std::sqrt(x2_[i] / n);
      f.rms_d_cm[i] = std::sqrt(d2_[i] / n);
      f.rms_xa_cm_s2[i] = std::sqrt(a2_[i] / n);
    }
    f.rms_force_n = std::sqrt(f2_ / n);
    return f;
  }

 private:
  std::uint64_t n_ = 0;
  StructureFigures f_;
  double x2_[3] = {}, d2_[3] = {}, a2_[3] = {}, f2_ = 0.0;
};

}  // namespace mrd::hil
