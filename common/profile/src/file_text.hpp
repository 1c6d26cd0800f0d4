#pragma once
// Reading a small text file for the configuration: regular files only (a FIFO, device or
// directory is refused, and opening never blocks), at most max_bytes.
#include <cstddef>
#include <string>

namespace mrd::profile {

// false with *error "PATH: reason" (cannot open, not a regular file, larger than the cap).
bool ReadTextFile(const std::string& path, std::size_t max_bytes, std::string* text,
                  std::string* error);

}  // namespace mrd::profile
