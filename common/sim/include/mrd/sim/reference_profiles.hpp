#pragma once
// Reference experiments (docs/design.md §4): excitation profiles and the data sets they produce
// when they drive the Spencer reference damper. Deterministic for a given seed. One definition
// for `mrd generate` (host) and the harness's generated excitations (`[excitation] kind =
// "profile"`). Start-up code (allocates); no exceptions.

#include <cstdint>
#include <string>
#include <vector>

#include "mrd/sim/spencer_damper.hpp"

namespace mrd {

// Sampled excitation. Row k: time t[k] [s], displacement x[k] [cm], velocity v[k] [cm/s]
// (exact derivative of the displacement profile), and E[k] [V], the voltage applied over
// (t[k-1], t[k]] so that it acts on the force f[k] at t[k].
struct ReferenceExcitation {
  std::vector<double> t, x, v, E;
};

// Profile names accepted by MakeReferenceExcitation.
const std::vector<std::string>& ReferenceProfileNames();

// identification: 40 s, eight 5 s sinusoid segments (0.4-4 Hz, peak velocity 3-15 cm/s,
//   order shuffled by seed), voltage steps every 0.5 s over 0 ... 2.25 V (both ends
//   present).
// v1: 20 s composite: filtered random (multisine), saturated and non-saturated ramps, a
//   chirp; voltage a chirp for 2 s then random piecewise constant.
// v2: 20 s ramps at 2, 5, 10, 15 cm/s; 0 V in the first half, 2.25 V in the second.
// v3: 20 s earthquake-like (Kanai-Tajimi shaped multisine, Shinozuka-Sato envelope,
//   peak velocity 15 cm/s) at constant 2.25 V.
// wide: 20 s beyond the identification set: 2 cm sines at 1-4 Hz, then a random multisine;
//   velocity to about +-50 cm/s, displacement to about +-2 cm; voltage random levels over
//   0 ... 2.25 V (held 0.1-0.5 s).
// Sampling interval dt [s]. false (out unchanged) for an unknown name or dt <= 0.
bool MakeReferenceExcitation(const std::string& profile, std::uint64_t seed, double dt,
                             ReferenceExcitation* out);

// Drives the damper with the excitation (RK4, substeps per sample); the force f[k] [N] at
// each t[k].
std::vector<double> SimulateReferenceDamper(const SpencerParams& params,
                                            const ReferenceExcitation& ex, int substeps = 100);

}  // namespace mrd
