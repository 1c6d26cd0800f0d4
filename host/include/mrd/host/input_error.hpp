#pragma once
// Bad user input (data file, spec file, model file, flag): the CLI prints it and exits 2.

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

// Exit status of the CLI for bad input.
constexpr int kExitBadInput = 2;

}  // namespace mrd::host
