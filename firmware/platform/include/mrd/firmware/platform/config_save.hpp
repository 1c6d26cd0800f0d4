#pragma once
// Saving the running parameters back into the config file (mrd-firmware ctl save).

#include <string>

#include "mrd/firmware/platform/config.hpp"

namespace mrd::firmware::platform {

// Writes the running values of the runtime-tunable keys (config.hpp, Tunable::kRuntime) into
// the config file at path. Everything else in the file (the other keys, comments, layout)
// stays as it is: a key the file has is rewritten in place, a missing one is added under its
// section's header (in a new section at the end when the file has none). Only keys whose
// running value differs from the file's are touched. The new text must parse back to the
// running values; it is written atomically (temporary, fsync, rename, fsync of the folder).
// "" on success, else the reason (the file unchanged). Not real-time.
std::string SaveConfigFile(const std::string& path, const FirmwareConfig& running);

}  // namespace mrd::firmware::platform
