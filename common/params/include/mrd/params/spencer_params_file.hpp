#pragma once
// Spencer damper parameter files (TOML), as `mrd generate --params` reads, `mrd fit-spencer`
// writes and a HIL scenario's `[plant] params` names:
//
//   preset = "spencer1997"   # optional base: "paper" (default) or "spencer1997"
//   c0a = 20.2               # any subset of the 14 SpencerParams fields overrides the base
//
// Units as spencer_damper.hpp: [N s/cm], [N/cm], [cm], [1/cm^2], [1/s]. Physical ranges
// (CheckPhysical): c0a, c1a, k0, eta > 0; c0b, c1b, k1, alpha_a, alpha_b, gamma, A >= 0;
// n in [1, 10]; beta and x0 finite.

#include <cstddef>
#include <string>

#include "mrd/sim/spencer_damper.hpp"

namespace mrd::params {

struct ParamsError {
  std::size_t line = 0;  // 1-based; 0 when not tied to a line
  std::string reason;
};

// The 14 field names in file order, with a pointer into p (for writers and overrides).
struct SpencerField {
  const char* key;
  double* value;
};
constexpr std::size_t kSpencerFieldCount = 14;
void SpencerFields(SpencerParams* p, SpencerField (&out)[kSpencerFieldCount]);

// Sets one field by key; false when the key is unknown.
bool SetSpencerField(SpencerParams* p, const std::string& key, double value);

// true when physical; else false with the reason ("'c0b' must be >= 0 (is -1)"), in *why.
bool CheckPhysical(const SpencerParams& p, std::string* why);

// Reads a parameter file. false: *error = line and reason (the caller adds the path).
// Unknown keys, non-numbers, an unknown preset, a syntax error and non-physical values are
// refused; a non-physical value's line is that of its key (or of the preset).
bool LoadSpencerParamsFile(const std::string& path, SpencerParams* out, ParamsError* error);

// The text of a parameter file holding every field (round-trip precision), as fit-spencer
// writes it; header: comment text, each line prefixed with "# ".
std::string SpencerParamsText(const SpencerParams& p, const std::string& header);

}  // namespace mrd::params
