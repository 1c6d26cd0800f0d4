#pragma once
// mrd-hil's output files (study, sweep): written whole or not at all.

#include <string>

namespace mrd::hil {

// Temporary in the same directory, fsync, rename over path (mode 0644); false with *error
// ("PATH: cannot create a temporary file", "PATH: cannot write"), the temporary removed.
bool WriteAtomically(const std::string& path, const std::string& text, std::string* error);

}  // namespace mrd::hil
