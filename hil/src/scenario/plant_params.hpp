#pragma once
// The scenario's damper parameters (scenario_checks_plant.cpp): [plant] preset or params file, then
// the [plant.spencer] overrides, checked for physical values. Start-up only.

#include <toml++/toml.h>

#include <string>

#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil {

// Sets s->damper from s->preset / s->params_file (already resolved) and the overrides table
// (may be nullptr). false: *error = "FILE:LINE: reason" (the parameter file's own line for
// errors inside it; the scenario's line for the overrides).
bool ResolvePlantDamper(const std::string& scenario_path, const toml::table& root,
                        const toml::table* overrides, Scenario* s, std::string* error);

}  // namespace mrd::hil
