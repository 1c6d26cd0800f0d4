#pragma once
// Invertibility of a model in its command input E: the property the firmware's inversion (and
// any controller that asks the model for a command) relies on. Per state, allocation-free, so
// the host's checks, the firmware and language bindings share one definition.
//
// State: the history of sample k prepared up to the command (ModelRunner::Begin, or
// RegressorHistory::Hold for a steady state); the command's own slot is not read. In it the
// model's normalised output is a polynomial y(e) of degree <= kMaxInputDegree in the normalised
// command e = (E - offset_E) / scale_E (E(k) enters through identity or low-pass regressors
// only: CheckInversion in table.hpp), and the force f(E) = Denormalise(y(e)).
//
// A state passes over the command range [e_min, e_max] [V] when
//   - monotone in the dissipative direction: df/dE * sign(v) >= -tolerance everywhere (an MR
//     damper's dissipative force grows with the coil field; v the velocity at sample k; at
//     v == 0 there is no dissipative direction and this holds);
//   - one-to-one: df/dE does not take both signs beyond the tolerance (else two commands give
//     one force and the inverter's choice jumps between them).
// tolerance [force unit per command unit] >= 0: slopes within +-tolerance count as flat; the
// default (DefaultSlopeTolerance) is a slope that moves the force by kFlatForceShare of the
// output's scale over the whole command range.
// The extremes of df/dE on the range are exact: the ends and the roots of d2f/dE2 (degree
// <= 2, closed form); no iteration.

#include <array>
#include <cstddef>
#include <cstdint>

#include "mrd/common/model.hpp"
#include "mrd/common/table.hpp"

namespace mrd {

// Share of the output's scale a slope must move the force by over the whole command range to
// count as a rise or a fall (below it: flat).
inline constexpr double kFlatForceShare = 0.01;

// kFlatForceShare * output_scale / (e_max - e_min) [force unit per command unit]; 0 for an
// empty or non-finite range.
double DefaultSlopeTolerance(double output_scale, double e_min, double e_max);

struct InvertibilityLimits {
  double e_min = 0.0;      // command range checked [V]
  double e_max = 2.25;     // [V], > e_min
  double tolerance = 0.0;  // [force unit per command unit], >= 0
};

struct StateInvertibility {
  bool monotone = true;    // df/dE * sign(v) >= -tolerance on the range
  bool one_to_one = true;  // df/dE does not take both signs beyond the tolerance
  // Lowest df/dE * s on the range [force unit per command unit], s = sign(v) (+1 at v == 0),
  // and the command where it is reached [V].
  double worst_slope = 0.0;
  double worst_e = 0.0;
  double min_slope = 0.0;  // lowest and highest df/dE on the range (no sign applied)
  double max_slope = 0.0;
  bool ok() const { return monotone && one_to_one; }
};

// Coefficients a_0 ... a_kMaxInputDegree of the normalised output as a polynomial in the
// normalised command at delay 0 of channel input_channel, in the state h. Precondition: the
// model enters that channel at delay 0 only through identity or low-pass regressors with a
// total degree <= kMaxInputDegree per term (CheckInversion); other factors of such terms are
// ignored. Real-time safe.
template <class T>
std::array<T, kMaxInputDegree + 1> InputPolynomial(const BasicModel<T>& model,
                                                   std::size_t input_channel,
                                                   const BasicRegressorHistory<T>& h);

// The same for one term with coefficient 1 (the model's polynomial is the sum of theta_i times
// these): lets a caller that varies the coefficients keep the terms' polynomials.
template <class T>
std::array<T, kMaxInputDegree + 1> TermInputPolynomial(const BasicModel<T>& model, const Term& term,
                                                       std::size_t input_channel,
                                                       const BasicRegressorHistory<T>& h);

// The verdict of one state from its polynomial a (normalised units), the input's and the
// output's normalisation and the sign of the velocity (-1, 0, +1). Real-time safe.
template <class T>
StateInvertibility CheckInputPolynomial(const std::array<T, kMaxInputDegree + 1>& a,
                                        const BasicChannelScale<T>& input,
                                        const BasicChannelScale<T>& output, int velocity_sign,
                                        const InvertibilityLimits& limits);

// InputPolynomial then CheckInputPolynomial; velocity: the raw velocity of sample k (only its
// sign is used). Real-time safe.
template <class T>
StateInvertibility CheckStateInvertibility(const BasicModel<T>& model, std::size_t input_channel,
                                           const BasicRegressorHistory<T>& h, T velocity,
                                           const InvertibilityLimits& limits);

}  // namespace mrd
