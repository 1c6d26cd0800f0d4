#pragma once
// Output files of the host programs (mrd-hil study and sweep, mrd-structure): written whole or
// not at all.

#include <string>

namespace mrd {

// Temporary in the same directory (mkstemp), fsync, rename over path (mode 0644); false with
// *error = "PATH: cannot write: REASON" (strerror), the temporary removed, path untouched.
bool WriteAtomically(const std::string& path, const std::string& text, std::string* error);

}  // namespace mrd
