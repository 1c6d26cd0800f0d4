#pragma once
// The identification spec `mrd identify` uses when no --spec is given: the text of
// host/specs/paper-saturating.toml, compiled in at build time (host/src/default_spec.cpp.in).

namespace mrd::host {

// Name the built-in spec carries in messages and in model files.
inline constexpr const char* kDefaultSemSpecName = "paper-saturating.toml (built in)";

// The TOML text of host/specs/paper-saturating.toml as it was when the tool was built.
const char* DefaultSemSpecText();

}  // namespace mrd::host
