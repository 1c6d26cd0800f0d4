#pragma once
// [excitation] kind = "replay" in a scenario (scenario_checks_run.cpp; plants/replay.hpp). Start-up
// only.

#include <toml++/toml.h>

#include <string>

#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil {

// Sets s->excitation = kReplay and resolves 'file' (needed) against the scenario's folder.
// false: *error = "FILE:LINE: reason".
bool CheckReplay(const std::string& path, const toml::table& root, Scenario* s, std::string* error);

}  // namespace mrd::hil
