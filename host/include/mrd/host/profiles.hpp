#pragma once
// Reference experiments (docs/design.md §4) for the host: the common definitions
// (mrd/common/reference_profiles.hpp, shared with the harness's generated excitations) with
// exceptions for bad arguments.

#include <cstdint>
#include <string>
#include <vector>

#include "mrd/common/reference_profiles.hpp"

namespace mrd::host {

using Excitation = mrd::ReferenceExcitation;

// Profile names accepted by MakeExcitation.
const std::vector<std::string>& ProfileNames();

// The profile's excitation (reference_profiles.hpp). Throws std::invalid_argument for an
// unknown name or dt <= 0.
Excitation MakeExcitation(const std::string& profile, std::uint64_t seed, double dt = 1e-3);

// Drives the damper with the excitation; returns the force f[k] [N] at each t[k].
std::vector<double> SimulateDamper(const SpencerParams& params, const Excitation& ex,
                                   int substeps = 100);

}  // namespace mrd::host
