#pragma once
// A road for four wheels: left and right ISO 8608 tracks of a stated correlation, the rear axle
// on the front axle's road a wheelbase later.
//
// Coherence model (shared plus independent component): three independent realisations of one
// class (iso8608_road.hpp), S (shared), L and R, from seeds derived from the one seed, mixed
//
//   hL(s) = sqrt(rho) S(s) + sqrt(1 - rho) L(s),   hR(s) = sqrt(rho) S(s) + sqrt(1 - rho) R(s)
//
// so each track keeps the class's PSD Gd(n) (the weights' squares sum to 1), the cross-PSD is
// rho Gd(n) and the coherence |Gx|^2 / (GL GR) = rho^2 at every wavelength: a frequency-flat
// simplification (measured roads are nearly coherent at long waves and incoherent at short ones;
// this model does not represent that). rho = 1: one track under both sides (no roll input);
// rho = 0: independent tracks.
//
// Wheelbase: the rear wheels run on the same tracks at s - wheelbase, the front at s (s = the
// front axle's distance). The road is a function of distance, so this is an exact delay line:
// a rear wheel's input at time t is the front wheel's at t - wheelbase / speed, whatever the
// step (no interpolation, no buffer). Stepping is RoadTrack's phasor rotation (6 tracks, the
// road's components each); allocation only in the constructor. Deterministic from the seed.

#include <array>
#include <cstdint>

#include "mrd/sim/full_car.hpp"
#include "mrd/sim/iso8608_road.hpp"

namespace mrd {

struct TwoTrackRoadParams {
  RoadParams road;           // class, seed, band, components (of each realisation)
  double correlation = 0.5;  // rho in [0, 1]: left/right height correlation
  double wheelbase_m = 2.6;  // > 0 (FullCarParams::wheelbase_m())

  // True when the values are finite and in range; on failure *reason names the field.
  bool IsValid(const char** reason) const;
};

class TwoTrackRoad {
 public:
  // ds_m: distance per Advance (speed * period), >= 0. Invalid parameters are the caller's to
  // check (IsValid); an invalid road gives flat tracks, as Iso8608Road.
  TwoTrackRoad(const TwoTrackRoadParams& params, double ds_m);

  // Front axle back at s = 0. Real-time safe.
  void Reset();
  // One ds further. Real-time safe.
  void Advance();
  double distance_m() const { return shared_front_.distance_m(); }  // front axle's s
  // Height [m] and slope dh/ds [-] under each wheel at the current distance.
  const CornerValues& heights_m() const { return height_; }
  const CornerValues& slopes() const { return slope_; }

  // Exact height [m] of the left (left = true) or right track at distance s [m].
  double TrackHeight(bool left, double s_m) const;
  const TwoTrackRoadParams& params() const { return params_; }

 private:
  void Collect();
  TwoTrackRoadParams params_;
  double ws_, wi_;  // sqrt(rho), sqrt(1 - rho)
  Iso8608Road shared_, left_, right_;
  RoadTrack shared_front_, left_front_, right_front_, shared_rear_, left_rear_, right_rear_;
  CornerValues height_{}, slope_{};
};

}  // namespace mrd
