#pragma once
// `--set KEY=VALUE` overrides of a scenario's TOML, applied to the parsed file before the
// scenario is read (so the file's checks apply to them too).

#include <toml++/toml.h>

#include <string>
#include <vector>

namespace mrd::hil {

// Merges each "KEY=VALUE" into root: KEY a dotted path of bare TOML keys (letters, digits, _
// and -), VALUE a TOML value (number, bool, string, array, inline table); a VALUE that parses
// as none of them is taken as a string (law=skyhook). Nodes it adds carry the source path
// "--set KEY=VALUE" so a later error names the override. false with *error
// ("--set 'SPEC': reason") when SPEC is malformed.
bool ApplyScenarioSets(const std::vector<std::string>& sets, toml::table* root, std::string* error);

}  // namespace mrd::hil
