#pragma once
// Reading a small text file for the configuration: regular files only (a FIFO, device or
// directory is refused, and opening never blocks), at most max_bytes.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace mrd::profile {

// false with *error "PATH: reason" (cannot open, not a regular file, larger than the cap).
bool ReadTextFile(const std::string& path, std::size_t max_bytes, std::string* text,
                  std::string* error);

// FNV-1a over text, continued from seed: a profile's fingerprint (a reload compares them).
inline std::uint64_t TextDigest(std::string_view text, std::uint64_t seed = 14695981039346656037U) {
  std::uint64_t h = seed;
  for (const char c : text) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211U;
  return h;
}

}  // namespace mrd::profile
