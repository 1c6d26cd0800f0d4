#include "mrd/host/profiles.hpp"

#include <stdexcept>

namespace mrd::host {

const std::vector<std::string>& ProfileNames() { return ReferenceProfileNames(); }

Excitation MakeExcitation(const std::string& profile, std::uint64_t seed, double dt) {
  if (!(dt > 0.0)) throw std::invalid_argument("sampling interval must be positive");
  Excitation ex;
  if (!MakeReferenceExcitation(profile, seed, dt, &ex)) {
    throw std::invalid_argument("unknown profile '" + profile +
                                "' (expected identification, v1, v2, v3 or wide)");
  }
  return ex;
}

std::vector<double> SimulateDamper(const SpencerParams& params, const Excitation& ex,
                                   int substeps) {
  return SimulateReferenceDamper(params, ex, substeps);
}

}  // namespace mrd::host
