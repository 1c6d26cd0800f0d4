#pragma once
// The clipped-optimal gains file: the TOML `mrd-structure design --out FILE` writes, read by
// mrd-firmware at start-up ([clipped_optimal] gains = "FILE"; docs/control_laws.md).
//
//   [control.clipped_optimal]
//   ad = [36 numbers]   bd = [6]   cy = [18]   dy = [3]   l = [18]   k = [6]   (row-major)
//   v_max = 2.25        v_min = 0.0                                               [V]
//   dampers = m         (optional, default 1; up to kMaxDampers force inputs: bd = [6 m],
//                        dy = [3 m] with m numbers per row, k = [6 m] one row per damper)
//
// Every key but dampers is required, no other key or table is allowed, every number must be finite,
// v_min <= v_max, and the observer's error dynamics (ad - l cy) must be stable (a wrong or
// mixed-up file would make the estimate diverge). Start-up only (allocates; toml++ throws
// inside and is caught).

#include <string>
#include <string_view>

#include "mrd/firmware/clipped_optimal.hpp"

namespace mrd::firmware::platform {

// Longest gains file [bytes].
inline constexpr std::uint64_t kMaxGainsBytes = 1 << 20;

// Parses TOML text (source names it in messages). false with *error = "SOURCE:LINE: reason".
bool ParseClippedOptimalGains(std::string_view text, const std::string& source,
                              ClippedOptimalGains* gains, std::string* error);
// Reads and parses a file (a regular file of at most kMaxGainsBytes); false with *error.
bool LoadClippedOptimalGains(const std::string& path, ClippedOptimalGains* gains,
                             std::string* error);
// True when every eigenvalue of ad - l cy lies inside the unit circle (checked as the decay
// of its 2^20-th power: stable observers of a 1 ms design decay there by far).
bool ClippedObserverStable(const ClippedOptimalGains& gains);

}  // namespace mrd::firmware::platform
