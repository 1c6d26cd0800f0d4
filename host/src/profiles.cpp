#include "mrd/host/profiles.hpp"

#include <cstddef>
#include <stdexcept>

namespace mrd::host {

Excitation MakeExcitation(const std::string& profile, std::uint64_t seed, double dt) {
  if (!(dt > 0.0)) throw std::invalid_argument("sampling interval must be positive");
  Excitation ex;
  if (!MakeReferenceExcitation(profile, seed, dt, &ex)) {
    // "a, b, c or d" from the sim's list.
    const std::vector<std::string>& names = ReferenceProfileNames();
    std::string expected;
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (i > 0) expected += i + 1 == names.size() ? " or " : ", ";
      expected += names[i];
    }
    throw std::invalid_argument("unknown profile '" + profile + "' (expected " + expected + ")");
  }
  return ex;
}

}  // namespace mrd::host
