#pragma once
// Bad user input (data file, spec file, model file, flag): the CLI prints it and exits 2.

#include <cstdint>
#include <stdexcept>
#include <string>

namespace mrd::host {

class InputError : public std::runtime_error {
 public:
  // file: path of the offending file ("" for a flag); line: 1-based, 0 when not applicable.
  InputError(const std::string& file, std::size_t line, const std::string& reason);

  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }

 private:
  std::string file_;
  std::size_t line_;
};

// Size caps of the host's input files [bytes].
constexpr std::uint64_t kMaxDataFileBytes = std::uint64_t{1} << 30;     // CSV data, 1 GiB
constexpr std::uint64_t kMaxModelFileBytes = std::uint64_t{256} << 20;  // model JSON, 256 MiB
constexpr std::uint64_t kMaxSpecFileBytes = std::uint64_t{1} << 20;     // spec TOML, 1 MiB

// Largest |value| a data file may hold: far beyond any measurement, and squares of a million
// of them still sum to a finite number.
constexpr double kMaxDataMagnitude = 1e100;

// The whole content of a regular file of at most max_bytes (mrd::ReadInputFile). Throws
// InputError(path, 0, reason): "is a directory, not a regular file", too large, unreadable.
std::string ReadInputText(const std::string& path, std::uint64_t max_bytes);

// Exit status of the CLI for bad input.
constexpr int kExitBadInput = 2;

}  // namespace mrd::host
