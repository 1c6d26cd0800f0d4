#pragma once
// Reference experiments (docs/design.md §4) for the host: the sim's definitions
// (mrd/sim/reference_profiles.hpp, shared with the harness's generated excitations) with
// exceptions for bad arguments. Names: ReferenceProfileNames(); the force of an excitation:
// SimulateReferenceDamper (both of the sim, no host layer).

#include <cstdint>
#include <string>
#include <vector>

#include "mrd/sim/reference_profiles.hpp"

namespace mrd::host {

using Excitation = mrd::ReferenceExcitation;

// The profile's excitation (reference_profiles.hpp). Throws std::invalid_argument for an
// unknown name or dt <= 0.
Excitation MakeExcitation(const std::string& profile, std::uint64_t seed, double dt = 1e-3);

}  // namespace mrd::host
