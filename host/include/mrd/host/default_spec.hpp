#pragma once
// The identification specs `mrd identify` chooses from when no --spec is given, compiled in at
// build time (host/src/default_spec.cpp.in): host/specs/paper-saturating.toml (the reference
// damper's saturating spec) and host/specs/nees.toml (the measured-damper spec). Each is
// identified on the data and the one whose selected model predicts data it was not fitted on
// best is kept (sem_default.hpp).

#include <span>

namespace mrd::host {

struct BuiltInSpec {
  const char* name;  // as messages and model files name it, e.g. "nees.toml (built in)"
  const char* text;  // the TOML text of the shipped file as it was when the tool was built
};

// In the order they are tried (a tie keeps the earlier).
std::span<const BuiltInSpec> BuiltInSemSpecs();

}  // namespace mrd::host
