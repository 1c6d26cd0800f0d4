#pragma once
// The candidate spec from an already parsed TOML table: the one validation behind both a spec
// file (ParseSemSpec, candidate_spec.hpp) and the spec stored in a model file (model_file.cpp
// builds the table from its JSON). Errors name `path`; a table built in memory has no source
// lines, so they carry line 0.

#include <toml++/toml.h>

#include <string>

#include "mrd/host/candidate_spec.hpp"

namespace mrd::host {

SemSpec SemSpecFromTable(const toml::table& tbl, const std::string& path);

}  // namespace mrd::host
