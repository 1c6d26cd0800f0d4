#include "mrd/hil/plants/excitation_profile.hpp"

#include <utility>

#include "mrd/sim/reference_profiles.hpp"

namespace mrd::hil {

bool ProfileTrace(const std::string& profile, std::uint64_t seed, const SpencerParams& params,
                  Trace* trace, std::string* error) {
  ReferenceExcitation ex;
  if (!MakeReferenceExcitation(profile, seed, 1e-3, &ex)) {
    std::string names;
    for (const std::string& n : ReferenceProfileNames()) names += (names.empty() ? "" : ", ") + n;
    *error = "unknown profile '" + profile + "' (" + names + ")";
    return false;
  }
  Trace t;
  t.demand = SimulateReferenceDamper(params, ex, kProfileDemandSubsteps);
  t.x = std::move(ex.x);
  t.v = std::move(ex.v);
  *trace = std::move(t);
  return true;
}

}  // namespace mrd::hil
